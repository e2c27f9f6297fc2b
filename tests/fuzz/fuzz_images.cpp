// Image files of recordings (io/image_io.h) and label images of the evaluation
// (eval/segmentation_metrics.h): instance masks, depth and colour, decoded by OpenCV and checked
// by the project's readers. Only PNG input is fuzzed (the format of TUM images and of masks, which
// must be lossless): OpenCV picks the decoder by content, and other decoders' own header
// allocations (OpenEXR reserved 1.8 GB for a 60-byte input) are theirs, not the readers'.
#include <cstring>

#include "eval/segmentation_metrics.h"
#include "fuzz_input.h"
#include "io/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static constexpr std::uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size < sizeof kPngSignature || std::memcmp(data, kPngSignature, sizeof kPngSignature) != 0) return 0;
  const auto path = cofusion::fuzz::write_input("image.png", data, size);
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
