#include "renderer/image.h"

#include <cstring>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"

namespace cofusion::renderer {

std::vector<uint8_t> encode_png(const Image& image) {
  if (image.width <= 0 || image.height <= 0 || image.rgba.size() != static_cast<size_t>(image.width) * image.height)
    throw Error("PNG encoding: empty or inconsistent image (" + std::to_string(image.width) + "x" +
                std::to_string(image.height) + ")");
  // Memory order R,G,B,A is what OpenCV calls RGBA; PNG is written from BGR.
  const cv::Mat rgba(image.height, image.width, CV_8UC4, const_cast<uint32_t*>(image.rgba.data()));
  cv::Mat bgr;
  cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", bgr, bytes)) throw Error("PNG encoding failed");
  return bytes;
}

Image read_png(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) throw Error("image " + path.string() + ": no such file");
  const cv::Mat bgr = cv::imread(path.string(), cv::IMREAD_COLOR);
  if (bgr.empty()) throw Error("image " + path.string() + ": not a readable image");
  cv::Mat rgba;
  cv::cvtColor(bgr, rgba, cv::COLOR_BGR2RGBA);
  Image out(rgba.cols, rgba.rows);
  for (int y = 0; y < rgba.rows; ++y)
    std::memcpy(&out.at(0, y), rgba.ptr(y), static_cast<size_t>(rgba.cols) * 4);
  return out;
}

}  // namespace cofusion::renderer
