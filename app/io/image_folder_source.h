#pragma once
// Co-Fusion / MaskFusion style image folders:
//   FOLDER/colour/ (or color/, rgb/)  8-bit colour images
//   FOLDER/depth/                     16-bit depth (millimetres by default) or 32-bit float
//                                     EXR/TIFF in metres
//   FOLDER/masks/                     optional 8/16-bit instance-id images (lossless: PNG etc.),
//                                     with an optional masks/classes.txt (io/instance_classes.h)
//   FOLDER/calibration.txt            "fx fy cx cy [w h]"
//   FOLDER/timestamps.txt             optional, one timestamp in seconds per frame
// Files are sorted by name (digit runs compared as numbers, so "img2" < "img10") and paired by
// position; the folders must hold the same number of images.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "io/frame.h"
#include "io/intrinsics_option.h"

namespace cofusion {

struct ImageFolderSourceOptions {
  // --intrinsics ("fx,fy,cx,cy[,w,h]", preset or file); empty = FOLDER/calibration.txt, else
  // primesense (and describe() says so).
  std::string intrinsics;
  double depth_units_per_metre = 1000.0;  // 16-bit depth scale (float depth is always metres)
  double frame_rate_hz = 30.0;            // timestamps = index / rate without timestamps.txt
};

// Image files (png, jpg, jpeg, exr, tif, tiff, ppm, pgm, bmp) of `dir` in natural name order.
std::vector<std::filesystem::path> list_images_sorted(const std::filesystem::path& dir);

class ImageFolderSource : public FrameSource {
 public:
  explicit ImageFolderSource(std::filesystem::path folder, ImageFolderSourceOptions options = {});

  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override { return intrinsics_.intrinsics; }
  std::optional<int> size() const override { return static_cast<int>(rgb_files_.size()); }
  std::string describe() const override;

 private:
  Frame read_frame(std::size_t i) const;

  std::filesystem::path folder_;
  ImageFolderSourceOptions options_;
  IntrinsicsChoice intrinsics_;
  std::vector<std::filesystem::path> rgb_files_, depth_files_, mask_files_;
  std::vector<double> timestamps_s_;
  std::shared_ptr<const InstanceClasses> mask_classes_;  // masks/classes.txt; null without one
  std::size_t next_ = 0;
};

}  // namespace cofusion
