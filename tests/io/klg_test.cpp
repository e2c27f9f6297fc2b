#include "io/klg.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <functional>
#include <limits>

#include "common/error.h"
#include "io/image_io.h"
#include "io/source_adaptors.h"
#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

using test::error_of;

constexpr int kW = 40, kH = 30;
const char* const kSize = "30,30,19.5,14.5,40,30";  // intrinsics option with the test image size

std::vector<Frame> test_frames(int n) {
  std::vector<Frame> frames;
  for (int i = 0; i < n; ++i) frames.push_back(test::make_test_frame(kW, kH, i, 1311868164.363181 + i * 0.0333));
  return frames;
}

Intrinsics test_intrinsics() {
  Intrinsics k;
  k.fx = k.fy = 30;
  k.cx = 19.5;
  k.cy = 14.5;
  k.width = kW;
  k.height = kH;
  return k;
}

fs::path write_test_log(const fs::path& dir, int n, KlgWriteOptions options = {}) {
  MemorySource source(test_frames(n), test_intrinsics());
  const fs::path path = dir / "test.klg";
  EXPECT_EQ(write_klg(source, path, options), n);
  return path;
}

KlgSource open_log(const fs::path& path) {
  KlgSourceOptions o;
  o.intrinsics = kSize;
  return KlgSource(path, o);
}

void put_i32(std::ofstream& out, std::int32_t v) { out.write(reinterpret_cast<const char*>(&v), sizeof v); }
void put_i64(std::ofstream& out, std::int64_t v) { out.write(reinterpret_cast<const char*>(&v), sizeof v); }

struct KlgCase {
  bool compress_depth;
  bool jpeg_colour;
};

class KlgRoundTrip : public ::testing::TestWithParam<KlgCase> {};

TEST_P(KlgRoundTrip, DepthExactColourAsStored) {
  const KlgCase c = GetParam();
  KlgWriteOptions w;
  w.compress_depth = c.compress_depth;
  w.jpeg_colour = c.jpeg_colour;
  const auto expected = test_frames(3);
  const fs::path path = write_test_log(test::fresh_temp_dir(), 3, w);
  // Raw blocks have exactly the raw sizes, which is how readers tell them apart.
  const auto file_size = fs::file_size(path);
  const std::uintmax_t raw_frame = 16 + kW * kH * 2 + kW * kH * 3;
  if (!c.compress_depth && !c.jpeg_colour) {
    EXPECT_EQ(file_size, 4 + 3 * raw_frame);
  } else {
    EXPECT_LT(file_size, 4 + 3 * raw_frame);
  }

  KlgSource source = open_log(path);
  EXPECT_EQ(source.size(), 3);
  EXPECT_EQ(source.intrinsics().width, kW);
  for (const Frame& e : expected) {
    auto f = source.next();
    ASSERT_TRUE(f);
    EXPECT_EQ(f->index, e.index);
    EXPECT_NEAR(f->timestamp_s, e.timestamp_s, 0.5e-6);  // microseconds in the file
    ASSERT_EQ(f->depth_m.type(), CV_32FC1);
    ASSERT_EQ(f->rgb.type(), CV_8UC3);
    // Depth is exact in the file's unit (millimetres), zeros included.
    EXPECT_EQ(cv::norm(depth_to_u16(f->depth_m, 1000), depth_to_u16(e.depth_m, 1000), cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::countNonZero(f->depth_m == 0), cv::countNonZero(e.depth_m == 0));
    if (c.jpeg_colour) {
      EXPECT_LT(cv::norm(f->rgb, e.rgb, cv::NORM_L1) / (kW * kH * 3), 6.0);  // lossy, but channel order kept
    } else {
      EXPECT_EQ(cv::norm(f->rgb, e.rgb, cv::NORM_INF), 0.0);
    }
  }
  EXPECT_FALSE(source.next());
}

INSTANTIATE_TEST_SUITE_P(Formats, KlgRoundTrip,
                         ::testing::Values(KlgCase{true, true}, KlgCase{true, false}, KlgCase{false, true},
                                           KlgCase{false, false}),
                         [](const ::testing::TestParamInfo<KlgCase>& p) {
                           return std::string(p.param.compress_depth ? "Zlib" : "RawDepth") +
                                  (p.param.jpeg_colour ? "Jpeg" : "RawRgb");
                         });

TEST(KlgSource, MissingColourIsBlack) {
  const fs::path path = test::fresh_temp_dir() / "nocolour.klg";
  Frame f = test::make_test_frame(kW, kH, 0, 1.0);
  f.rgb.release();
  MemorySource source({f}, test_intrinsics());
  write_klg(source, path);
  KlgSource log = open_log(path);
  auto g = log.next();
  ASSERT_TRUE(g);
  EXPECT_EQ(g->rgb.size(), cv::Size(kW, kH));
  EXPECT_EQ(cv::countNonZero(g->rgb.reshape(1)), 0);
}

TEST(KlgSource, TruncatedLogNamesTheFrame) {
  const fs::path dir = test::fresh_temp_dir();
  const fs::path path = write_test_log(dir, 3);
  const auto size = fs::file_size(path);
  fs::resize_file(path, size - 10);  // inside frame 2's colour block
  std::string msg = error_of([&] { open_log(path); });
  EXPECT_THAT(msg, HasSubstr(path.string()));
  EXPECT_THAT(msg, HasSubstr("frame 2"));
  EXPECT_THAT(msg, HasSubstr("truncated"));

  // Cut inside frame 0's 16-byte header.
  const fs::path path2 = write_test_log(dir, 2);
  fs::resize_file(path2, 4 + 10);
  msg = error_of([&] { open_log(path2); });
  EXPECT_THAT(msg, HasSubstr("frame 0"));
  EXPECT_THAT(msg, HasSubstr("truncated"));

  fs::resize_file(path2, 2);
  EXPECT_THAT(error_of([&] { open_log(path2); }), HasSubstr(path2.string()));
}

TEST(KlgSource, ZeroOrNegativeFrameCount) {
  const fs::path dir = test::fresh_temp_dir();
  {
    std::ofstream out(dir / "empty.klg", std::ios::binary);
    put_i32(out, 0);
  }
  std::string msg = error_of([&] { open_log(dir / "empty.klg"); });
  EXPECT_THAT(msg, HasSubstr((dir / "empty.klg").string()));
  EXPECT_THAT(msg, HasSubstr("no frames"));

  // A log whose writer never came back to fill in the count (Logger2 writes it on close).
  const fs::path unfinished = write_test_log(dir, 2);
  {
    std::fstream out(unfinished, std::ios::binary | std::ios::in | std::ios::out);
    const std::int32_t zero = 0;
    out.write(reinterpret_cast<const char*>(&zero), sizeof zero);
  }
  msg = error_of([&] { open_log(unfinished); });
  EXPECT_THAT(msg, HasSubstr(unfinished.string()));
  EXPECT_THAT(msg, HasSubstr("not closed properly"));

  {
    std::ofstream out(dir / "negative.klg", std::ios::binary);
    put_i32(out, -3);
  }
  EXPECT_THAT(error_of([&] { open_log(dir / "negative.klg"); }), HasSubstr("negative frame count"));
  EXPECT_THAT(error_of([&] { open_log(dir / "missing.klg"); }), HasSubstr((dir / "missing.klg").string()));
}

// Found by fuzz_klg: a damaged count (here 2^31 - 1 frames in a 8-byte file) reserved 24 bytes per
// frame it claimed (50 GB) before the frame walk found the log truncated.
TEST(KlgSource, AHugeFrameCountInAShortFileIsTruncationNotAnAllocation) {
  const fs::path dir = test::fresh_temp_dir();
  {
    std::ofstream out(dir / "huge.klg", std::ios::binary);
    put_i32(out, std::numeric_limits<std::int32_t>::max());
    put_i32(out, 0x0e020e02);
  }
  const std::string msg = error_of([&] { open_log(dir / "huge.klg"); });
  EXPECT_THAT(msg, HasSubstr((dir / "huge.klg").string()));
  EXPECT_THAT(msg, HasSubstr("frame 0"));
  EXPECT_THAT(msg, HasSubstr("truncated"));
}

TEST(KlgSource, WrongImageSizeNamesTheFrame) {
  const fs::path path = write_test_log(test::fresh_temp_dir(), 2);
  // Read with the default 640x480: the zlib depth block is too small for that size.
  KlgSource source(path);
  const std::string msg = error_of([&] { source.next(); });
  EXPECT_THAT(msg, HasSubstr(path.string()));
  EXPECT_THAT(msg, HasSubstr("frame 0"));
  EXPECT_THAT(msg, HasSubstr("640x480"));

  // Raw depth read with a different size: the block is then taken as zlib and is not.
  KlgWriteOptions raw;
  raw.compress_depth = false;
  const fs::path raw_path = write_test_log(test::fresh_temp_dir("raw"), 1, raw);
  KlgSourceOptions o;
  o.intrinsics = "30,30,19.5,14.5,20,15";
  const std::string raw_msg = error_of([&] {
    KlgSource small(raw_path, o);
    small.next();
  });
  EXPECT_THAT(raw_msg, HasSubstr(raw_path.string()));
  EXPECT_THAT(raw_msg, HasSubstr("frame 0"));
}

TEST(KlgSource, DecompressedSizeMismatchNamesTheFrame) {
  // A hand-written frame whose depth decompresses to half the expected size.
  const fs::path path = test::fresh_temp_dir() / "short_depth.klg";
  std::vector<std::uint8_t> half(kW * kH, 7);
  std::vector<std::uint8_t> packed(compressBound(half.size()));
  uLongf packed_size = packed.size();
  ASSERT_EQ(compress2(packed.data(), &packed_size, half.data(), half.size(), 1), Z_OK);
  {
    std::ofstream out(path, std::ios::binary);
    put_i32(out, 1);
    put_i64(out, 1000000);
    put_i32(out, static_cast<std::int32_t>(packed_size));
    put_i32(out, 0);
    out.write(reinterpret_cast<const char*>(packed.data()), static_cast<std::streamsize>(packed_size));
  }
  KlgSource source = open_log(path);
  const std::string msg = error_of([&] { source.next(); });
  EXPECT_THAT(msg, HasSubstr("frame 0"));
  EXPECT_THAT(msg, HasSubstr("decompresses to 1200 bytes, expected 2400"));
}

TEST(KlgSource, CorruptJpegIsABadFrameAndTheLogGoesOn) {
  const fs::path path = write_test_log(test::fresh_temp_dir(), 3);
  // Overwrite the start of frame 1's JPEG (its SOI marker) with garbage.
  KlgSource probe = open_log(path);
  ASSERT_TRUE(probe.next());
  std::ifstream in(path, std::ios::binary);
  std::int32_t count = 0, d0 = 0, r0 = 0, d1 = 0;
  std::int64_t ts = 0;
  in.read(reinterpret_cast<char*>(&count), 4);
  in.read(reinterpret_cast<char*>(&ts), 8);
  in.read(reinterpret_cast<char*>(&d0), 4);
  in.read(reinterpret_cast<char*>(&r0), 4);
  const std::streamoff frame1 = 4 + 16 + d0 + r0;
  in.seekg(frame1 + 8);
  in.read(reinterpret_cast<char*>(&d1), 4);
  in.close();
  {
    std::fstream out(path, std::ios::binary | std::ios::in | std::ios::out);
    out.seekp(frame1 + 16 + d1);
    out.write("garbage!", 8);
  }
  KlgSource source = open_log(path);
  ASSERT_TRUE(source.next());
  try {
    source.next();
    ADD_FAILURE() << "the corrupt frame read without an error";
  } catch (const BadFrame& e) {
    EXPECT_EQ(e.frame_index(), 1);
    EXPECT_THAT(e.reason(), HasSubstr("frame 1"));
    EXPECT_THAT(e.reason(), HasSubstr("JPEG"));
  }
  const auto after = source.next();
  ASSERT_TRUE(after);
  EXPECT_EQ(after->index, 2);
  EXPECT_FALSE(source.next());
}

TEST(KlgWriter, AtomicAndChecksFrames) {
  const fs::path dir = test::fresh_temp_dir();
  {
    KlgWriter writer(dir / "a.klg", kW, kH);
    writer.write(test::make_test_frame(kW, kH, 0, 0.0));
    EXPECT_FALSE(fs::exists(dir / "a.klg"));  // nothing under the final name before finish()
  }
  EXPECT_FALSE(fs::exists(dir / "a.klg"));
  EXPECT_TRUE(fs::is_empty(dir));  // and no temporary left behind

  KlgWriter writer(dir / "b.klg", kW, kH);
  writer.write(test::make_test_frame(kW, kH, 0, 0.0));
  const std::string msg = error_of([&] { writer.write(test::make_test_frame(kW + 1, kH, 1, 0.1)); });
  EXPECT_THAT(msg, HasSubstr("frame 1"));
  EXPECT_THAT(msg, HasSubstr("41x30, expected 40x30"));
  writer.finish();
  EXPECT_EQ(open_log(dir / "b.klg").size(), 1);

  EXPECT_THAT(error_of([&] { KlgWriter w("/nonexistent-dir/x.klg", kW, kH); }), HasSubstr("/nonexistent-dir/x.klg"));
}

}  // namespace
}  // namespace cofusion
