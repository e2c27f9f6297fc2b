#pragma once
// Rolling shutter: a colour camera that exposes its rows one after another sees each row from the
// pose it had at that row's time, so a fast turn shears and stretches the image. The frame's pose
// is the one at its middle row; unwarp_colour resamples every other row to that pose.
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "common/intrinsics.h"

namespace cofusion::slam {

struct RollingShutterParams {
  // Time from the colour image's first row to its last, seconds; negative when the rows are read
  // from the bottom up; 0 = a global shutter (nothing is resampled); unset = as the input says
  // (CoFusion::note_frame_time; TUM's fr1 Kinect: 0.02 s). Depth is not resampled.
  std::optional<double> colour_readout_s;
  // The frame interval, seconds, where the input gives no timestamps (CoFusion::note_frame_time).
  double nominal_frame_interval_s = 1.0 / 30.0;
};

// The colour image as a global shutter at its middle row would have seen it, for a camera moving
// with constant body velocity `camera_motion` (T_previous_current) over `interval_s`. Rotation
// only: a pixel's ray is turned by the rotation between its row's time and the middle row's (the
// translation within one readout moves a pixel by well under one at the ranges involved), and the
// colour is sampled bilinearly where the ray met the image; pixels whose ray left the image are
// black. `rgb` and `out` are width x height x 3 bytes and must not overlap.
void unwarp_colour(const uint8_t* rgb, const Intrinsics& K, const Eigen::Isometry3d& camera_motion, double interval_s,
                   double readout_s, uint8_t* out);

// The rotation from row `v`'s camera to the middle row's camera (unwarp_colour's per-row turn).
Eigen::Matrix3d row_rotation(int v, int height, const Eigen::Vector3d& angular_velocity_rad_s, double readout_s);

// A pipeline's colour frames without their rolling shutter (RollingShutterParams): the frame
// times and readout the input gives, and the buffer the resampled colour lives in until the next
// frame. CoFusion and DenseSlam share it, so that `bench`'s figures for either do the work `run` does.
class ColourUnwarper {
 public:
  explicit ColourUnwarper(RollingShutterParams params = {}) : params_(params) {}

  // The next frame's time (seconds; frames without timestamps are taken
  // RollingShutterParams::nominal_frame_interval_s apart) and its colour camera's readout time as
  // the input gives it (RollingShutterParams::colour_readout_s overrides it).
  void note_frame_time(double t_s, double input_colour_readout_s);

  // The frame's colour as its middle row's pose would have seen it, for a camera that moved by
  // `last_motion` (T_previous_current) over the last frame; `rgb` itself where there is no
  // readout, no turn, or no motion to go by (`have_motion` false: the first frame, a lost camera).
  const uint8_t* unwarp(const uint8_t* rgb, const Intrinsics& K, const Eigen::Isometry3d& last_motion, bool have_motion);

  // The readout time in use, seconds (0: a global shutter).
  double readout_s() const { return params_.colour_readout_s.value_or(input_colour_readout_s_); }

 private:
  RollingShutterParams params_;
  std::deque<double> frame_times_s_;  // note_frame_time's, the last three
  double input_colour_readout_s_ = 0.0;
  std::vector<uint8_t> unwarped_rgb_;
};

}  // namespace cofusion::slam
