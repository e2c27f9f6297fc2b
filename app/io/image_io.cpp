#include "io/image_io.h"

#include <cctype>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <span>
#include <system_error>
#include <vector>

#include "common/error.h"
#include "io/atomic_file.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {

cv::Mat load(const fs::path& path, int flags, const char* what) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw Error(std::string(what) + " image " + path.string() + " does not exist");
  cv::Mat image;
  try {
    image = cv::imread(path.string(), flags);
  } catch (const cv::Exception& e) {
    throw Error(std::string(what) + " image " + path.string() + " cannot be decoded: " + e.what());
  }
  if (image.empty()) throw Error(std::string(what) + " image " + path.string() + " cannot be decoded");
  return image;
}

std::string type_name(const cv::Mat& m) {
  static const char* depths[] = {"8U", "8S", "16U", "16S", "32S", "32F", "64F", "16F"};
  return std::string(depths[m.depth()]) + "C" + std::to_string(m.channels());
}

}  // namespace

cv::Mat read_rgb_image(const fs::path& path) {
  cv::Mat image = load(path, cv::IMREAD_UNCHANGED, "colour");
  if (image.depth() != CV_8U)
    throw Error("colour image " + path.string() + " has pixel type " + type_name(image) + ", expected 8-bit");
  cv::Mat rgb;
  switch (image.channels()) {
    case 1: cv::cvtColor(image, rgb, cv::COLOR_GRAY2RGB); break;
    case 3: cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB); break;
    case 4: cv::cvtColor(image, rgb, cv::COLOR_BGRA2RGB); break;
    default:
      throw Error("colour image " + path.string() + " has " + std::to_string(image.channels()) + " channels");
  }
  return rgb;
}

cv::Mat read_depth_image(const fs::path& path, double units_per_metre) {
  if (!(units_per_metre > 0) || !std::isfinite(units_per_metre))
    throw Error("depth image " + path.string() + ": depth scale must be positive, got " + std::to_string(units_per_metre));
  const cv::Mat image = load(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR, "depth");
  if (image.channels() != 1)
    throw Error("depth image " + path.string() + " has " + std::to_string(image.channels()) +
                " channels, expected a single-channel 16-bit or float image");
  cv::Mat depth_m;
  switch (image.depth()) {
    case CV_16U: image.convertTo(depth_m, CV_32F, 1.0 / units_per_metre); break;
    case CV_32F: depth_m = image; break;
    case CV_64F: image.convertTo(depth_m, CV_32F); break;
    default:
      throw Error("depth image " + path.string() + " has pixel type " + type_name(image) +
                  ", expected 16-bit integer or 32-bit float");
  }
  sanitize_depth(depth_m);
  return depth_m;
}

cv::Mat read_mask_image(const fs::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".jpg" || ext == ".jpeg")
    throw Error("mask image " + path.string() + " is a JPEG: masks must be lossless (PNG), or their ids change");
  const cv::Mat image = load(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR, "mask");
  if (image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    throw Error("mask image " + path.string() + " has pixel type " + type_name(image) +
                ", expected single-channel 8- or 16-bit instance ids");
  cv::Mat mask;
  image.convertTo(mask, CV_16U);
  return mask;
}

void sanitize_depth(cv::Mat& depth_m) {
  CV_Assert(depth_m.type() == CV_32FC1);
  depth_m.forEach<float>([](float& d, const int*) {
    if (!std::isfinite(d) || d < 0.0f) d = 0.0f;
  });
}

void require_image_size(const cv::Mat& image, int width, int height, const std::string& what) {
  if (image.cols != width || image.rows != height)
    throw Error(what + ": image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + ", expected " +
                std::to_string(width) + "x" + std::to_string(height));
}

cv::Mat depth_to_u16(const cv::Mat& depth_m, double units_per_metre) {
  CV_Assert(depth_m.type() == CV_32FC1);
  cv::Mat out(depth_m.size(), CV_16UC1);
  for (int y = 0; y < depth_m.rows; ++y) {
    const float* src = depth_m.ptr<float>(y);
    auto* dst = out.ptr<std::uint16_t>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      const double units = std::round(static_cast<double>(src[x]) * units_per_metre);
      dst[x] = (std::isfinite(units) && units > 0 && units <= 65535.0) ? static_cast<std::uint16_t>(units) : 0;
    }
  }
  return out;
}

void write_rgb_image(const fs::path& path, const cv::Mat& rgb) {
  if (rgb.type() != CV_8UC3) throw Error("cannot write " + path.string() + ": colour image is not CV_8UC3");
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(path.extension().string(), bgr, bytes))
    throw Error("cannot write " + path.string() + ": image encoding failed");
  write_bytes_atomically(path, std::as_bytes(std::span(bytes.data(), bytes.size())));
}

void write_u16_png(const fs::path& path, const cv::Mat& image_u16) {
  if (image_u16.type() != CV_16UC1) throw Error("cannot write " + path.string() + ": image is not CV_16UC1");
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", image_u16, bytes)) throw Error("cannot write " + path.string() + ": PNG encoding failed");
  write_bytes_atomically(path, std::as_bytes(std::span(bytes.data(), bytes.size())));
}

}  // namespace cofusion
