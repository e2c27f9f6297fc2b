#pragma once
// Writes frames as a TUM RGB-D folder that TumSource (and the benchmark's tools) read back:
//   rgb/<t>.png (8-bit), depth/<t>.png (16-bit, 5000 units per metre, 0 = no reading),
//   masks/<t>.png (16-bit instance ids, when frames carry masks), masks/classes.txt (when those
//   frames carry a class table, io/instance_classes.h), rgb.txt, depth.txt,
//   associations.txt, groundtruth.txt (when frames carry ground truth) and calibration.txt
//   ("fx fy cx cy w h"). <t> is the frame timestamp with 6 decimals.
// Every file is written atomically; the text files are written by finish().
#include <filesystem>
#include <memory>
#include <string>

#include "io/frame.h"
#include "io/trajectory.h"

namespace cofusion {

struct TumWriteOptions {
  double depth_units_per_metre = 5000.0;  // TUM scale; depth beyond 65535 units (13.1 m) becomes 0
  bool write_calibration = true;          // calibration.txt with the intrinsics
};

class TumFolderWriter {
 public:
  // Creates `dir`, rgb/ and depth/ and checks they are writable; all frames must match `intrinsics`
  // in size.
  TumFolderWriter(std::filesystem::path dir, const Intrinsics& intrinsics, TumWriteOptions options = {});

  // Writes the frame's images. Throws cofusion::Error naming the frame when its timestamp does
  // not increase, its images have the wrong size or type, or it has a mask when earlier frames
  // had none (or the other way round), or its mask class table differs from an earlier frame's.
  void write(const Frame& frame);
  // Writes the lists (and ground truth, calibration, the masks' class table). Call once after the
  // last frame.
  void finish();
  int frames_written() const { return frames_; }

 private:
  // Remembers the class table of a frame's mask; all frames must share one.
  void keep_mask_classes(const Frame& frame, const std::string& where);

  std::filesystem::path dir_;
  Intrinsics intrinsics_;
  TumWriteOptions options_;
  int frames_ = 0;
  bool masks_ = false;
  std::shared_ptr<const InstanceClasses> mask_classes_;  // of the first frame that has one
  double last_timestamp_s_ = 0;
  std::string rgb_list_, depth_list_, associations_;
  Trajectory groundtruth_;
};

// Writes every frame of `source` into `dir`; returns the number of frames written.
int write_tum_folder(FrameSource& source, const std::filesystem::path& dir, const TumWriteOptions& options = {});

}  // namespace cofusion
