#pragma once
// Small synthetic images and folders for the io tests, written with OpenCV directly so the
// readers under test are checked against an independent writer.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "io/frame.h"

namespace cofusion::test {

// Colour with a per-frame pattern (R,G,B order) and depth in whole millimetres (some zeros),
// so depth survives 16-bit millimetre storage exactly.
inline Frame make_test_frame(int w, int h, int index, double timestamp_s) {
  Frame f;
  f.index = index;
  f.timestamp_s = timestamp_s;
  f.intrinsics.width = w;
  f.intrinsics.height = h;
  f.rgb = cv::Mat(h, w, CV_8UC3);
  f.depth_m = cv::Mat(h, w, CV_32FC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uchar>(x * 4 + index), static_cast<uchar>(y * 4),
                                            static_cast<uchar>((x + y + 10 * index) % 256));
      const int mm = ((x + y) % 7 == 0) ? 0 : 500 + 10 * x + 7 * y + index;
      f.depth_m.at<float>(y, x) = static_cast<float>(mm) / 1000.0f;
    }
  return f;
}

inline void write_bgr_png(const std::filesystem::path& path, const cv::Mat& rgb) {
  std::filesystem::create_directories(path.parent_path());
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  cv::imwrite(path.string(), bgr);
}

inline void write_png(const std::filesystem::path& path, const cv::Mat& image) {
  std::filesystem::create_directories(path.parent_path());
  cv::imwrite(path.string(), image);
}

inline cv::Mat depth_units(const cv::Mat& depth_m, double units_per_metre) {
  cv::Mat out;
  depth_m.convertTo(out, CV_16U, units_per_metre);
  return out;
}

inline void write_text(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

}  // namespace cofusion::test
