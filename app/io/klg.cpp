#include "io/klg.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "io/image_io.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {

constexpr double kMillimetresPerMetre = 1000.0;

template <class T>
bool read_value(std::ifstream& in, T& value) {
  in.read(reinterpret_cast<char*>(&value), sizeof value);
  return static_cast<bool>(in);
}

template <class T>
void write_value(std::ofstream& out, const T& value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof value);
}

}  // namespace

KlgSource::KlgSource(fs::path path, KlgSourceOptions options) : path_(std::move(path)) {
  if (options.intrinsics.empty()) {
    intrinsics_.intrinsics = *intrinsics_preset("primesense");
    intrinsics_.size_known = true;
    intrinsics_.origin = "primesense default (no --intrinsics given)";
  } else {
    intrinsics_ = parse_intrinsics_option(options.intrinsics);
  }
  require_plausible(intrinsics_.intrinsics, "klg log " + path_.string() + " (" + intrinsics_.origin + ")");

  std::error_code ec;
  if (!fs::is_regular_file(path_, ec)) throw Error("klg log " + path_.string() + " does not exist");
  const std::uint64_t file_size = fs::file_size(path_, ec);
  in_.open(path_, std::ios::binary);
  if (!in_ || ec) throw Error("cannot open klg log " + path_.string());

  std::int32_t count = 0;
  if (!read_value(in_, count)) throw Error("klg log " + path_.string() + " is shorter than its 4-byte frame count");
  if (count < 0) throw Error("klg log " + path_.string() + " has a negative frame count (" + std::to_string(count) + ")");
  if (count == 0) {
    if (file_size > sizeof count)
      throw Error("klg log " + path_.string() + " has frame count 0 but " + std::to_string(file_size - sizeof count) +
                  " bytes of frames follow (the log was not closed properly)");
    throw Error("klg log " + path_.string() + " holds no frames");
  }

  const std::uint64_t depth_raw = 2ull * intrinsics_.intrinsics.width * intrinsics_.intrinsics.height;
  std::uint64_t offset = sizeof count;
  // Every frame takes at least its 16-byte header and one depth byte: a damaged count reserves no
  // more entries than the file can hold.
  constexpr std::uint64_t min_frame_bytes = sizeof(std::int64_t) + 2 * sizeof(std::int32_t) + 1;
  entries_.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(count, (file_size - sizeof count) / min_frame_bytes)));
  for (std::int32_t i = 0; i < count; ++i) {
    Entry e;
    constexpr std::uint64_t header = sizeof e.timestamp_us + sizeof e.depth_size + sizeof e.rgb_size;
    if (offset + header > file_size || !read_value(in_, e.timestamp_us) || !read_value(in_, e.depth_size) ||
        !read_value(in_, e.rgb_size))
      throw Error(where(entries_.size()) + ": log is truncated (frame header missing; the header says " +
                  std::to_string(count) + " frames)");
    if (e.depth_size <= 0 || e.rgb_size < 0 || static_cast<std::uint64_t>(e.depth_size) > 2 * depth_raw + 1024)
      throw Error(where(entries_.size()) + ": implausible block sizes (depth " + std::to_string(e.depth_size) + ", rgb " +
                  std::to_string(e.rgb_size) + " bytes for " + std::to_string(intrinsics_.intrinsics.width) + "x" +
                  std::to_string(intrinsics_.intrinsics.height) + " images)");
    e.data_offset = offset + header;
    offset = e.data_offset + static_cast<std::uint64_t>(e.depth_size) + static_cast<std::uint64_t>(e.rgb_size);
    if (offset > file_size)
      throw Error(where(entries_.size()) + ": log is truncated (frame needs " + std::to_string(offset) +
                  " bytes, the file has " + std::to_string(file_size) + ")");
    entries_.push_back(e);
    in_.seekg(static_cast<std::streamoff>(offset));
  }
}

std::string KlgSource::where(std::size_t frame) const {
  return "klg log " + path_.string() + " frame " + std::to_string(frame);
}

std::optional<Frame> KlgSource::next() {
  if (next_ >= entries_.size()) return std::nullopt;
  const std::size_t i = next_++;  // past this frame even when it is bad
  return read_or_bad_frame(static_cast<int>(i), [&] { return read_frame(i); });
}

Frame KlgSource::read_frame(std::size_t i) {
  const Entry& e = entries_[i];
  const int w = intrinsics_.intrinsics.width;
  const int h = intrinsics_.intrinsics.height;
  const std::size_t depth_raw = 2ull * w * h;

  Frame frame;
  frame.index = static_cast<int>(i);
  frame.timestamp_s = static_cast<double>(e.timestamp_us) * 1e-6;
  frame.intrinsics = intrinsics_.intrinsics;

  in_.clear();
  in_.seekg(static_cast<std::streamoff>(e.data_offset));
  buffer_.resize(static_cast<std::size_t>(e.depth_size) + static_cast<std::size_t>(e.rgb_size));
  if (!in_.read(reinterpret_cast<char*>(buffer_.data()), static_cast<std::streamsize>(buffer_.size())))
    throw Error(where(i) + ": read failed (file changed or truncated while reading)");

  cv::Mat depth_mm(h, w, CV_16UC1);
  if (static_cast<std::size_t>(e.depth_size) == depth_raw) {
    std::memcpy(depth_mm.data, buffer_.data(), depth_raw);
  } else {
    uLongf out_size = static_cast<uLongf>(depth_raw);
    const int rc = uncompress(depth_mm.data, &out_size, buffer_.data(), static_cast<uLong>(e.depth_size));
    if (rc == Z_BUF_ERROR)
      throw Error(where(i) + ": depth block decompresses to more than " + std::to_string(depth_raw) + " bytes (" +
                  std::to_string(w) + "x" + std::to_string(h) + "x2); wrong image size in the intrinsics?");
    if (rc != Z_OK) throw Error(where(i) + ": depth block is not valid zlib data (zlib error " + std::to_string(rc) + ")");
    if (out_size != depth_raw)
      throw Error(where(i) + ": depth block decompresses to " + std::to_string(out_size) + " bytes, expected " +
                  std::to_string(depth_raw) + " (" + std::to_string(w) + "x" + std::to_string(h) +
                  "x2); wrong image size in the intrinsics?");
  }
  depth_mm.convertTo(frame.depth_m, CV_32F, 1.0 / kMillimetresPerMetre);

  const std::uint8_t* rgb_bytes = buffer_.data() + e.depth_size;
  if (e.rgb_size == 0) {
    frame.rgb = cv::Mat(h, w, CV_8UC3, cv::Scalar::all(0));
  } else if (static_cast<std::size_t>(e.rgb_size) == 3ull * w * h) {
    frame.rgb = cv::Mat(h, w, CV_8UC3);
    std::memcpy(frame.rgb.data, rgb_bytes, static_cast<std::size_t>(e.rgb_size));
  } else {
    const cv::Mat encoded(1, e.rgb_size, CV_8UC1, const_cast<std::uint8_t*>(rgb_bytes));
    cv::Mat bgr;
    try {
      bgr = cv::imdecode(encoded, cv::IMREAD_COLOR);
    } catch (const cv::Exception&) {
      bgr.release();
    }
    if (bgr.empty())
      throw Error(where(i) + ": colour block (" + std::to_string(e.rgb_size) + " bytes) is neither raw " +
                  std::to_string(w) + "x" + std::to_string(h) + " RGB nor a decodable JPEG");
    require_image_size(bgr, w, h, where(i) + " colour JPEG");
    cv::cvtColor(bgr, frame.rgb, cv::COLOR_BGR2RGB);
  }
  return frame;
}

std::string KlgSource::describe() const {
  return "klg:" + path_.string() + " (" + std::to_string(entries_.size()) + " frames, " + intrinsics_.origin + ": " +
         intrinsics_.intrinsics.to_string() + ")";
}

KlgWriter::KlgWriter(fs::path path, int width, int height, KlgWriteOptions options)
    : file_(std::move(path)), width_(width), height_(height), options_(options) {
  if (width <= 0 || height <= 0) throw Error("cannot write klg log " + file_.path().string() + ": image size must be positive");
  out_.open(file_.tmp_path(), std::ios::binary | std::ios::trunc);
  if (!out_) throw Error("cannot write klg log " + file_.path().string() + ": cannot create " + file_.tmp_path().string());
  write_value(out_, std::int32_t{0});  // frame count, filled in by finish()
}

void KlgWriter::write(const Frame& frame) {
  const std::string where = "klg log " + file_.path().string() + " frame " + std::to_string(frames_);
  if (frame.depth_m.type() != CV_32FC1) throw Error(where + ": depth is not CV_32FC1 metres");
  require_image_size(frame.depth_m, width_, height_, where + " depth");
  if (!frame.rgb.empty()) {
    if (frame.rgb.type() != CV_8UC3) throw Error(where + ": colour is not CV_8UC3");
    require_image_size(frame.rgb, width_, height_, where + " colour");
  }

  const cv::Mat depth_mm = depth_to_u16(frame.depth_m, kMillimetresPerMetre);  // continuous
  const std::size_t depth_raw = depth_mm.total() * depth_mm.elemSize();
  const std::uint8_t* depth_bytes = depth_mm.data;
  std::size_t depth_size = depth_raw;
  if (options_.compress_depth) {
    uLongf size = compressBound(static_cast<uLong>(depth_raw));
    compressed_.resize(size);
    if (compress2(compressed_.data(), &size, depth_mm.data, static_cast<uLong>(depth_raw), Z_BEST_SPEED) != Z_OK)
      throw Error(where + ": zlib compression failed");
    // A compressed block exactly the raw size would be read back as raw: store raw then.
    if (size != depth_raw) {
      depth_bytes = compressed_.data();
      depth_size = size;
    }
  }

  std::vector<std::uint8_t> rgb_bytes;
  if (!frame.rgb.empty()) {
    cv::Mat rgb = frame.rgb.isContinuous() ? frame.rgb : frame.rgb.clone();
    if (options_.jpeg_colour) {
      cv::Mat bgr;
      cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
      if (!cv::imencode(".jpg", bgr, rgb_bytes, {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality}))
        throw Error(where + ": JPEG encoding failed");
      // A JPEG exactly w*h*3 bytes long would be read back as raw: store raw then.
      if (rgb_bytes.size() == rgb.total() * 3) rgb_bytes.clear();
    }
    if (rgb_bytes.empty()) rgb_bytes.assign(rgb.data, rgb.data + rgb.total() * 3);
  }

  const auto timestamp_us = static_cast<std::int64_t>(std::llround(frame.timestamp_s * 1e6));
  write_value(out_, timestamp_us);
  write_value(out_, static_cast<std::int32_t>(depth_size));
  write_value(out_, static_cast<std::int32_t>(rgb_bytes.size()));
  out_.write(reinterpret_cast<const char*>(depth_bytes), static_cast<std::streamsize>(depth_size));
  out_.write(reinterpret_cast<const char*>(rgb_bytes.data()), static_cast<std::streamsize>(rgb_bytes.size()));
  if (!out_) throw Error(where + ": write failed (disk full?)");
  ++frames_;
}

void KlgWriter::finish() {
  if (file_.committed()) return;
  out_.seekp(0);
  write_value(out_, static_cast<std::int32_t>(frames_));
  out_.close();
  if (!out_) throw Error("cannot write klg log " + file_.path().string() + ": write failed (disk full?)");
  file_.commit();
}

int write_klg(FrameSource& source, const fs::path& path, const KlgWriteOptions& options) {
  const Intrinsics k = source.intrinsics();
  KlgWriter writer(path, k.width, k.height, options);
  while (auto frame = source.next()) writer.write(*frame);
  writer.finish();
  return writer.frames_written();
}

}  // namespace cofusion
