#include "slam/rolling_shutter.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace cofusion::slam {

// Row v is exposed at (v + 0.5) / height - 0.5 of the readout after the middle row; a camera
// turning at w (body frame) has turned by exp(w t) by then, which maps that row's rays into the
// middle row's camera.
Eigen::Matrix3d row_rotation(int v, int height, const Eigen::Vector3d& angular_velocity_rad_s, double readout_s) {
  const double t_s = ((v + 0.5) / height - 0.5) * readout_s;
  const Eigen::Vector3d w = angular_velocity_rad_s * t_s;
  const double angle = w.norm();
  return angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

namespace {

// A sample within half a pixel of the image takes its edge's colour; farther out, black.
void sample_bilinear(const uint8_t* rgb, int width, int height, double x, double y, uint8_t* px) {
  if (!(x >= -0.5 && y >= -0.5 && x <= width - 0.5 && y <= height - 0.5)) {
    px[0] = px[1] = px[2] = 0;
    return;
  }
  x = std::clamp(x, 0.0, width - 1.0), y = std::clamp(y, 0.0, height - 1.0);
  const int x0 = std::max(0, std::min(int(x), width - 2)), y0 = std::max(0, std::min(int(y), height - 2));
  const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
  const double fx = x - x0, fy = y - y0;
  for (int c = 0; c < 3; ++c) {
    const double top = (1 - fx) * rgb[(size_t(y0) * width + x0) * 3 + c] + fx * rgb[(size_t(y0) * width + x1) * 3 + c];
    const double bottom = (1 - fx) * rgb[(size_t(y1) * width + x0) * 3 + c] + fx * rgb[(size_t(y1) * width + x1) * 3 + c];
    px[c] = static_cast<uint8_t>(std::clamp(std::lround((1 - fy) * top + fy * bottom), 0L, 255L));
  }
}

}  // namespace

void unwarp_colour(const uint8_t* rgb, const Intrinsics& K, const Eigen::Isometry3d& camera_motion, double interval_s,
                   double readout_s, uint8_t* out) {
  const int width = K.width, height = K.height;
  const Eigen::AngleAxisd turn(camera_motion.rotation());
  const Eigen::Vector3d w = interval_s > 0 ? Eigen::Vector3d(turn.axis() * turn.angle() / interval_s) : Eigen::Vector3d::Zero();
  tbb::parallel_for(0, height, [&](int v) {
    // The output pixel's ray in the middle row's camera, turned back into row v's camera (the
    // output's row stands for the source's: the rows differ by a few pixels at most).
    const Eigen::Matrix3d R_row_middle = row_rotation(v, height, w, readout_s).transpose();
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      const Eigen::Vector3d r = R_row_middle * ray;
      uint8_t* px = out + (size_t(v) * width + u) * 3;
      if (r.z() <= 0) {
        px[0] = px[1] = px[2] = 0;
        continue;
      }
      sample_bilinear(rgb, width, height, K.fx * r.x() / r.z() + K.cx, K.fy * r.y() / r.z() + K.cy, px);
    }
  });
}

}  // namespace cofusion::slam
