// Image files of recordings (io/image_io.h) and label images of the evaluation
// (eval/segmentation_metrics.h): instance masks, depth and colour, decoded by OpenCV and checked
// by the project's readers. Two kinds of input:
// - a PNG file (it starts with PNG's signature): decoded as it is. Other formats are not fuzzed
//   this way: OpenCV picks the decoder by content, and other decoders' own header allocations
//   (OpenEXR reserved 1.8 GB for a 60-byte input) are theirs, not the readers'.
// - anything else describes an image - pixel type, channels, size, then pixel bytes - that is
//   encoded losslessly (PNG, or TIFF for float) and read back: what the readers must accept or
//   refuse, past libpng's checksums, which stop most mutated PNG files early.
#include <algorithm>
#include <array>
#include <cstring>
#include <opencv2/imgcodecs.hpp>

#include "eval/segmentation_metrics.h"
#include "fuzz_input.h"
#include "io/image_io.h"

namespace {

constexpr std::uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

// Bytes 0-2: type, width, height; the rest fills the pixels (repeated, or zeros when absent).
std::vector<std::uint8_t> encoded_image(const std::uint8_t* data, std::size_t size) {
  static constexpr std::array<int, 7> kTypes = {CV_8UC1, CV_16UC1, CV_8UC3, CV_8UC4, CV_16UC3, CV_8UC2, CV_32FC1};
  if (size < 3) return {};
  const int type = kTypes[data[0] % kTypes.size()];
  cv::Mat image(1 + data[2] % 48, 1 + data[1] % 64, type, cv::Scalar::all(0));
  const std::size_t bytes = image.total() * image.elemSize();
  for (std::size_t i = 0; i < bytes && size > 3; ++i) image.data[i] = data[3 + i % (size - 3)];
  std::vector<std::uint8_t> file;
  try {
    cv::imencode(type == CV_32FC1 ? ".tiff" : ".png", image, file);
  } catch (const cv::Exception&) {
    return {};  // a type the encoder does not write (e.g. 2 channels)
  }
  return file;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const bool png = size >= sizeof kPngSignature && std::memcmp(data, kPngSignature, sizeof kPngSignature) == 0;
  std::vector<std::uint8_t> file = png ? std::vector<std::uint8_t>(data, data + size) : encoded_image(data, size);
  if (file.empty()) return 0;
  const auto path = cofusion::fuzz::write_input("image.png", file.data(), file.size());
  try {
    cofusion::read_mask_image(path);
  } catch (const cofusion::Error&) {
  }
  try {
    cofusion::read_depth_image(path, 5000.0);
  } catch (const cofusion::Error&) {
  }
  try {
    cofusion::read_rgb_image(path);
  } catch (const cofusion::Error&) {
  }
  try {
    cofusion::eval::read_label_image(path);
  } catch (const cofusion::Error&) {
  }
  return 0;
}
