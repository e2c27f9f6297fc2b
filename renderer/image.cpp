#include "renderer/image.h"

#include <cstring>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "io/atomic_file.h"

namespace cofusion::renderer {

void write_png(const Image& image, const std::filesystem::path& path) {
  if (image.width <= 0 || image.height <= 0 || image.rgba.size() != static_cast<size_t>(image.width) * image.height)
    throw Error("screenshot " + path.string() + ": empty or inconsistent image (" + std::to_string(image.width) + "x" +
                std::to_string(image.height) + ")");
  // Memory order R,G,B,A is what OpenCV calls RGBA; PNG is written from BGR.
  const cv::Mat rgba(image.height, image.width, CV_8UC4, const_cast<uint32_t*>(image.rgba.data()));
  cv::Mat bgr;
  cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", bgr, bytes)) throw Error("screenshot " + path.string() + ": PNG encoding failed");
  write_bytes_atomically(path, std::as_bytes(std::span<const uchar>(bytes)));
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
