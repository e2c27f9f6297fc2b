#pragma once
// Rolling shutter: a colour camera that exposes its rows one after another sees each row from the
// pose it had at that row's time, so a fast turn shears and stretches the image. The frame's pose
// is the one at its middle row; unwarp_colour resamples every other row to that pose.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>

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

}  // namespace cofusion::slam
