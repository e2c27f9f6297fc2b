#pragma once
// A check of the camera's tracked motion against the previous frame's depth. Frame-to-model
// tracking can converge to a wrong pose when movers cover most of the view and the little
// background left is far and weakly constrained (Bonn crowd: the pose jumped 20-50 cm while the
// camera moved 2 mm). The previous frame is a measurement, not a model: at video rate almost every
// pixel of it, people included, is where the true motion puts the next frame's pixels, so a
// tracked motion that explains far fewer of them than the constant-velocity guess (or no motion)
// does is refused.
#include <Eigen/Geometry>

#include "common/intrinsics.h"

namespace cofusion::slam {

struct CameraCheckParams {
  bool enabled = true;
  // Every step_px-th pixel in x and y takes part (4: 4,800 of 640x480's pixels).
  int step_px = 4;
  // A live pixel fits where its point, moved into the previous camera, lands on a pixel whose depth
  // is within tolerance_rel * depth + tolerance_m of it (axial noise is about 1% of depth at 3 m
  // for Kinect-class sensors; the margin also absorbs a pixel's rounding).
  double tolerance_rel = 0.02;
  double tolerance_m = 0.01;
  // The tracked motion is refused when its fit is below this fraction of the better of the
  // constant-velocity guess's and no motion's. Correct tracking fits at least as well as either
  // (within a few percent of noise; the guess is off by the frame's change of velocity); the jumps
  // fit a third or less of what the guess does.
  double min_fit_ratio = 0.8;
};

// The share of live pixels with depth (every step_px-th in x and y) that fit the reference depth
// under T_reference_live (live camera -> reference camera), as CameraCheckParams defines; 0 when
// no live pixel has depth. `depth_live_m`, `depth_reference_m`: width*height metres, 0 or NaN =
// no reading, both of the size `intrinsics` gives.
double depth_fit(const float* depth_live_m, const float* depth_reference_m, const Intrinsics& intrinsics,
                 const Eigen::Isometry3d& T_reference_live, const CameraCheckParams& params);

}  // namespace cofusion::slam
