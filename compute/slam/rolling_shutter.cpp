#include "slam/rolling_shutter.h"

#include <tbb/parallel_for.h>

#include <opencv2/imgproc.hpp>

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

void unwarp_colour(const uint8_t* rgb, const Intrinsics& K, const Eigen::Isometry3d& camera_motion, double interval_s,
                   double readout_s, uint8_t* out) {
  const int width = K.width, height = K.height;
  const Eigen::AngleAxisd turn(camera_motion.rotation());
  const Eigen::Vector3d w = interval_s > 0 ? Eigen::Vector3d(turn.axis() * turn.angle() / interval_s) : Eigen::Vector3d::Zero();
  // Where each output pixel samples the input; a sample within half a pixel of the image takes its
  // edge's colour, one farther out is black (a map entry far outside, with a black border). The
  // map (2.4 MB at 640x480) is kept for the calling thread's next frame: create() reuses it while
  // the size stays. (The workers below reach it through this reference: a thread_local named in
  // the lambda would be each worker's own.)
  thread_local cv::Mat map_of_this_thread;
  cv::Mat& map = map_of_this_thread;
  map.create(height, width, CV_32FC2);
  tbb::parallel_for(0, height, [&](int v) {
    // The output pixel's ray in the middle row's camera, turned back into row v's camera (the
    // output's row stands for the source's: the rows differ by a few pixels at most). Along a row
    // the ray is affine in u.
    const Eigen::Matrix3d R_row_middle = row_rotation(v, height, w, readout_s).transpose();
    const Eigen::Vector3d first = R_row_middle * Eigen::Vector3d(-K.cx / K.fx, (v - K.cy) / K.fy, 1.0);
    const Eigen::Vector3d step = R_row_middle.col(0) / K.fx;
    auto* xy = map.ptr<cv::Vec2f>(v);
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d r = first + u * step;
      const double x = K.fx * r.x() / r.z() + K.cx, y = K.fy * r.y() / r.z() + K.cy;
      const bool inside = r.z() > 0 && x >= -0.5 && y >= -0.5 && x <= width - 0.5 && y <= height - 0.5;
      xy[u] = inside ? cv::Vec2f(float(std::clamp(x, 0.0, width - 1.0)), float(std::clamp(y, 0.0, height - 1.0)))
                     : cv::Vec2f(-16.0f, -16.0f);
    }
  });
  const cv::Mat in(height, width, CV_8UC3, const_cast<uint8_t*>(rgb));
  cv::Mat dst(height, width, CV_8UC3, out);
  cv::remap(in, dst, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
}

void ColourUnwarper::note_frame_time(double t_s, double input_colour_readout_s) {
  frame_times_s_.push_back(t_s);
  while (frame_times_s_.size() > 3) frame_times_s_.pop_front();
  input_colour_readout_s_ = input_colour_readout_s;
}

const uint8_t* ColourUnwarper::unwarp(const uint8_t* rgb, const Intrinsics& K, const Eigen::Isometry3d& last_motion,
                                      bool have_motion) {
  const double readout = readout_s();
  // Without a turn every row sees the middle row's view: the resampling would copy the image.
  if (readout == 0.0 || !have_motion || last_motion.rotation().isIdentity(0.0)) return rgb;
  // The last motion spans the two frames before this one.
  const size_t n = frame_times_s_.size();
  const double interval_s = n == 3 && frame_times_s_[1] > frame_times_s_[0] ? frame_times_s_[1] - frame_times_s_[0]
                                                                             : params_.nominal_frame_interval_s;
  unwarped_rgb_.resize(size_t(K.width) * K.height * 3);
  unwarp_colour(rgb, K, last_motion, interval_s, readout, unwarped_rgb_.data());
  return unwarped_rgb_.data();
}

}  // namespace cofusion::slam
