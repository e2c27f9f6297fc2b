#pragma once
// Single-model dense surfel SLAM (ElasticFusion-class, without loop closure): per frame,
// preprocess the live frame, predict the model into the previous view, track the camera against
// that prediction (ICP + photometric) and fuse the frame into the model. The multi-object
// system runs the same steps once per model.
#include <string>
#include <utility>
#include <vector>

#include "gpu/stream.h"
#include "kernels/preprocess.h"
#include "slam/rolling_shutter.h"
#include "slam/surfel_model.h"
#include "slam/tracker.h"

namespace cofusion::slam {

struct SlamParams {
  kernels::PreprocessParams preprocess;
  TrackerParams tracker;
  FusionParams fusion;
  // Tracking starts from the previous frame's motion repeated (constant velocity) instead of
  // no motion; helps fast camera motion.
  bool constant_velocity_guess = true;
  // Tracking's reference view holds stable surfels plus unstable ones at most this many frames
  // old (a young model has no stable surfels yet; old unconfirmed ones are mostly noise).
  // Measured: 10 instead of 30 takes TUM fr1/rpy (200 frames) from 3.3 to 2.7 cm ATE.
  int prediction_recent_window_frames = 10;
  // The colour camera's rolling shutter (0 = global shutter; unset = as note_frame_time says).
  RollingShutterParams rolling_shutter;

  // `preprocess` with what the tracker needs switched on (the live gradients of its ESM term).
  kernels::PreprocessParams effective_preprocess() const {
    kernels::PreprocessParams p = preprocess;
    p.live_gradients = p.live_gradients || tracker.needs_live_gradients();
    return p;
  }
};

struct FrameResult {
  int frame = 0;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  TrackingResult tracking;  // default (not failed) for the first frame
  bool tracked = false;     // false for the first frame
  FusionStats fusion;
  std::vector<std::pair<std::string, double>> stage_ms;  // wall-clock per stage, in order
};

// Thread safety: one thread at a time.
class DenseSlam {
 public:
  DenseSlam(gpu::Context& ctx, const Intrinsics& intrinsics, const SlamParams& params, uint32_t worker = 0);

  // Processes the next frame: `depth_m` width*height floats in metres (0/NaN = no reading),
  // `rgb` width*height*3 bytes. Returns the camera pose and diagnostics.
  // `rgb` is resampled for the colour camera's rolling shutter (SlamParams::rolling_shutter) by the
  // camera's last motion, as CoFusion does.
  FrameResult process(const float* depth_m, const uint8_t* rgb);
  // The next frame's time, seconds, and its colour camera's readout as the input gives it
  // (ColourUnwarper::note_frame_time); without calls, frames are taken as global-shutter ones.
  void note_frame_time(double t_s, double input_colour_readout_s) {
    unwarper_.note_frame_time(t_s, input_colour_readout_s);
  }

  const SurfelModel& model() const { return model_; }
  SurfelModel& model() { return model_; }
  gpu::Stream& stream() { return stream_; }
  const kernels::FramePyramid& live() const { return live_; }
  int frames_processed() const { return frame_; }

 private:
  gpu::Context& ctx_;
  SlamParams params_;
  gpu::Stream stream_;
  kernels::Preprocessor preprocessor_;
  SurfelPipelines surfels_;
  Tracker tracker_;
  kernels::FramePyramid live_;
  ModelPrediction prediction_;
  SurfelModel model_;
  int frame_ = 0;
  Eigen::Isometry3d T_world_camera_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d last_motion_ = Eigen::Isometry3d::Identity();  // T_{t-2}^{-1} T_{t-1}
  ColourUnwarper unwarper_;
};

}  // namespace cofusion::slam
