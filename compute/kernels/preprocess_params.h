#pragma once
// Parameters of frame preprocessing (the inputs of tracking). Units in the names; defaults
// follow KinectFusion / ElasticFusion practice for Kinect-class sensors.

namespace cofusion::kernels {

struct PreprocessParams {
  // Depth readings outside [min_depth_m, max_depth_m] are dropped (the depth cut-off).
  float min_depth_m = 0.3f;
  float max_depth_m = 5.0f;
  // Bilateral filter of depth before vertex/normal estimation; off = raw depth.
  bool bilateral = true;
  // A 3x3 window: on TUM fr2/desk and fr1/rpy it tracks as well as 5x5 at 40% of the cost
  // (7 vs 17 ms at 640x480 on lavapipe with 2 threads).
  int bilateral_radius_px = 1;           // window (2r+1)^2
  float bilateral_sigma_space_px = 1.5f; // spatial Gaussian
  float bilateral_sigma_depth_m = 0.03f; // range Gaussian: about Kinect noise at 2.5 m
  // Coarse-to-fine pyramid: level 0 is the input resolution, each further level halves it.
  int pyramid_levels = 4;
  // Depth downsampling ignores samples farther than this from the block's first valid one.
  float pyramid_max_depth_diff_m = 0.1f;
  // Intensity gradients of the live frame (the pipelines switch them on when the tracker's ESM
  // photometric term needs them: SlamParams::effective_preprocess).
  bool live_gradients = false;
};

}  // namespace cofusion::kernels
