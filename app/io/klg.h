#pragma once
// Kintinuous / ElasticFusion / Co-Fusion ".klg" logs. Layout (little-endian):
//   int32 frame count, then per frame: int64 timestamp (microseconds), int32 depth size,
//   int32 rgb size, depth bytes, rgb bytes.
// Depth is 16-bit millimetres, zlib-compressed, or raw when depth size == w*h*2. Colour is JPEG,
// or raw R,G,B when rgb size == w*h*3, or absent (size 0 -> black image). The image size is not
// stored: it comes from the intrinsics (640x480 by default).
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "io/atomic_file.h"
#include "io/frame.h"
#include "io/intrinsics_option.h"

namespace cofusion {

struct KlgSourceOptions {
  // --intrinsics ("fx,fy,cx,cy[,w,h]", preset or file); empty = primesense 640x480. Without w,h
  // in the option the images are taken to be 640x480.
  std::string intrinsics;
};

class KlgSource : public FrameSource {
 public:
  // Reads the frame count and walks the frame headers, so a truncated or inconsistent log fails
  // here with the frame index. Throws cofusion::Error naming the file. A block that does not
  // decode is a BadFrame from next().
  explicit KlgSource(std::filesystem::path path, KlgSourceOptions options = {});

  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override { return intrinsics_.intrinsics; }
  std::optional<int> size() const override { return static_cast<int>(entries_.size()); }
  std::string describe() const override;

 private:
  struct Entry {
    std::int64_t timestamp_us = 0;
    std::int32_t depth_size = 0;
    std::int32_t rgb_size = 0;
    std::uint64_t data_offset = 0;  // first byte of the depth block
  };
  std::string where(std::size_t frame) const;
  Frame read_frame(std::size_t i);

  std::filesystem::path path_;
  IntrinsicsChoice intrinsics_;
  std::ifstream in_;
  std::vector<Entry> entries_;
  std::size_t next_ = 0;
  std::vector<std::uint8_t> buffer_;
};

struct KlgWriteOptions {
  bool compress_depth = true;  // zlib (as Logger2 writes); false = raw 16-bit millimetres
  bool jpeg_colour = true;     // JPEG; false = raw R,G,B bytes
  int jpeg_quality = 90;       // 0..100
};

// Streams frames into a .klg log under a temporary name; finish() writes the frame count and
// renames the log into place. Destroyed without finish(), it leaves nothing behind.
class KlgWriter {
 public:
  // width/height: the image size every frame must have (it is not stored in the file).
  KlgWriter(std::filesystem::path path, int width, int height, KlgWriteOptions options = {});

  // Depth is stored in whole millimetres (readings beyond 65.535 m become 0); an empty rgb image
  // is stored as "no colour". Throws cofusion::Error naming the frame on a size or type mismatch.
  void write(const Frame& frame);
  void finish();
  int frames_written() const { return frames_; }

 private:
  PendingFile file_;
  std::ofstream out_;
  int width_;
  int height_;
  KlgWriteOptions options_;
  int frames_ = 0;
  std::vector<std::uint8_t> compressed_;
};

// Writes every frame of `source` to `path`; returns the number of frames written.
int write_klg(FrameSource& source, const std::filesystem::path& path, const KlgWriteOptions& options = {});

}  // namespace cofusion
