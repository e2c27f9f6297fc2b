#include "commands/frame_upload.h"

#include <cmath>
#include <vector>

#include "common/error.h"

namespace cofusion::commands {

void upload_frame(gpu::Stream& stream, const Frame& frame, kernels::FramePyramid& pyramid) {
  const auto& l0 = pyramid.levels.at(0);
  const std::string where = "frame " + std::to_string(frame.index);
  if (frame.depth_m.type() != CV_32FC1 || frame.rgb.type() != CV_8UC3)
    throw Error(where + ": expected float depth and RGB8 colour");
  if (frame.depth_m.cols != l0.width || frame.depth_m.rows != l0.height || frame.rgb.cols != l0.width ||
      frame.rgb.rows != l0.height)
    throw Error(where + ": image size " + std::to_string(frame.depth_m.cols) + "x" + std::to_string(frame.depth_m.rows) +
                " differs from the intrinsics' " + std::to_string(l0.width) + "x" + std::to_string(l0.height));
  const cv::Mat depth = frame.depth_m.isContinuous() ? frame.depth_m : frame.depth_m.clone();
  const cv::Mat rgb = frame.rgb.isContinuous() ? frame.rgb : frame.rgb.clone();
  pyramid.upload(stream, depth.ptr<float>(), rgb.data);
}

Frame make_builtin_test_frame(const Intrinsics& k) {
  Frame f;
  f.intrinsics = k;
  f.depth_m = cv::Mat(k.height, k.width, CV_32FC1);
  f.rgb = cv::Mat(k.height, k.width, CV_8UC3);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      // Ray direction through the pixel; intersect a back wall, a floor and a sphere.
      const double rx = (x - k.cx) / k.fx, ry = (y - k.cy) / k.fy;
      double z = 3.0;                                   // back wall at 3 m
      if (ry > 0.05) z = std::min(z, 1.2 / ry);         // floor 1.2 m below the camera
      const double sx = 0.3, sy = 0.1, sz = 1.8, r = 0.35;  // sphere
      const double b = rx * sx + ry * sy + sz, a = rx * rx + ry * ry + 1, c = sx * sx + sy * sy + sz * sz - r * r;
      const double disc = b * b - a * c;
      if (disc > 0) z = std::min(z, (b - std::sqrt(disc)) / a);
      if (rx < -0.25 && rx > -0.5 && ry > -0.1 && ry < 0.2) z = std::min(z, 1.5);  // a box face
      f.depth_m.at<float>(y, x) = static_cast<float>(z);
      const int checker = ((static_cast<int>(std::floor(rx * z * 10)) + static_cast<int>(std::floor(ry * z * 10))) & 1);
      const auto shade = static_cast<uint8_t>(60 + 120 * checker + static_cast<int>(20 * z));
      f.rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(shade, static_cast<uint8_t>(255 - shade), static_cast<uint8_t>(40 * z));
    }
  return f;
}

}  // namespace cofusion::commands
