#include "io/source_spec.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "common/error.h"
#include "io/source_adaptors.h"
#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

using test::error_of;

TEST(SourceSpec, SchemeAndPath) {
  auto s = parse_source_spec("tum:/data/fr2:desk");  // only the first colon separates
  EXPECT_EQ(s.scheme, "tum");
  EXPECT_EQ(s.path, "/data/fr2:desk");
  s = parse_source_spec("synthetic");
  EXPECT_EQ(s.scheme, "synthetic");
  EXPECT_EQ(s.path, "");
  s = parse_source_spec("synthetic:two_boxes");
  EXPECT_EQ(s.path, "two_boxes");
  s = parse_source_spec("openni2");
  EXPECT_EQ(s.scheme, "openni2");
  s = parse_source_spec("openni2:usb://1/2");
  EXPECT_EQ(s.path, "usb://1/2");
}

TEST(SourceSpec, UnknownSchemeAndMissingPath) {
  std::string msg = error_of([] { parse_source_spec("kinect:/dev/video0"); });
  EXPECT_THAT(msg, HasSubstr("'kinect:/dev/video0'"));
  EXPECT_THAT(msg, HasSubstr("unknown source scheme 'kinect'"));
  EXPECT_THAT(msg, HasSubstr("tum:PATH"));  // lists what would work
  for (const char* spec : {"tum:", "klg:", "oni:", "images:"}) {
    msg = error_of([&] { parse_source_spec(spec); });
    EXPECT_THAT(msg, HasSubstr("missing path after")) << spec;
    EXPECT_THAT(msg, HasSubstr(spec));
  }
  EXPECT_THAT(error_of([] { parse_source_spec(""); }), HasSubstr("no source given"));
  EXPECT_THAT(error_of([] { parse_source_spec("/no/such/recording.klg"); }), HasSubstr("'/no/such/recording.klg'"));
}

TEST(SourceSpec, BarePathsNameTheirKind) {
  const fs::path dir = test::fresh_temp_dir();
  test::write_text(dir / "log.klg", "");
  test::write_text(dir / "rec.oni", "");
  test::write_text(dir / "tum" / "rgb.txt", "");
  fs::create_directories(dir / "images" / "depth");
  EXPECT_EQ(parse_source_spec((dir / "log.klg").string()).scheme, "klg");
  EXPECT_EQ(parse_source_spec((dir / "rec.oni").string()).scheme, "oni");
  EXPECT_EQ(parse_source_spec((dir / "tum").string()).scheme, "tum");
  EXPECT_EQ(parse_source_spec((dir / "images").string()).scheme, "images");
  EXPECT_EQ(parse_source_spec((dir / "images").string()).path, (dir / "images").string());
}

TEST(SourceSpec, OpenRecordedSourceErrorsNameThePath) {
  EXPECT_THAT(error_of([] { open_recorded_source({"tum", "/no/such/folder"}, ""); }), HasSubstr("/no/such/folder"));
  EXPECT_THAT(error_of([] { open_recorded_source({"klg", "/no/such.klg"}, ""); }), HasSubstr("/no/such.klg"));
  EXPECT_THAT(error_of([] { open_recorded_source({"images", "/no/such/images"}, ""); }), HasSubstr("/no/such/images"));
  EXPECT_THAT(error_of([] { open_recorded_source({"oni", "/no/such.oni"}, ""); }), HasSubstr("/no/such.oni"));
  EXPECT_THAT(error_of([] { open_recorded_source({"synthetic", ""}, ""); }), HasSubstr("not a recorded source"));
}

TEST(SourceSpec, OpensTumWithIntrinsicsOption) {
  const auto dir = test::data_dir("tum_fr2_desk_50");
  if (!dir) GTEST_SKIP() << "tum_fr2_desk_50 not found";
  auto source = open_recorded_source(parse_source_spec("tum:" + dir->string()), "fr1");
  EXPECT_DOUBLE_EQ(source->intrinsics().fx, 517.3);
  EXPECT_THAT(error_of([&] { open_recorded_source({"tum", dir->string()}, "garbage"); }),
              HasSubstr("--intrinsics 'garbage'"));
}

// `n` 8x6 test frames at 10 Hz, and their intrinsics.
std::vector<Frame> small_frames(int n) {
  std::vector<Frame> frames;
  for (int i = 0; i < n; ++i) frames.push_back(test::make_test_frame(8, 6, i, i * 0.1));
  return frames;
}
Intrinsics small_intrinsics() {
  Intrinsics k;
  k.width = 8;
  k.height = 6;
  return k;
}

TEST(LimitedSource, StopsAtTheLimit) {
  const std::vector<Frame> frames = small_frames(5);
  const Intrinsics k = small_intrinsics();
  LimitedSource limited(std::make_unique<MemorySource>(frames, k, "five"), 3);
  EXPECT_EQ(limited.size(), 3);
  EXPECT_THAT(limited.describe(), HasSubstr("first 3 frames"));
  int n = 0;
  while (auto f = limited.next()) EXPECT_EQ(f->index, n++);
  EXPECT_EQ(n, 3);
  LimitedSource more(std::make_unique<MemorySource>(frames, k), 10);
  EXPECT_EQ(more.size(), 5);
  EXPECT_THAT(error_of([&] { LimitedSource bad(std::make_unique<MemorySource>(frames, k), -1); }),
              HasSubstr("--max-frames"));
}

TEST(DepthCorrectedSource, DividesEveryDepthReading) {
  std::vector<Frame> frames = small_frames(3);
  frames[1].depth_m.at<float>(2, 3) = 0.0f;  // no reading
  const Intrinsics k = small_intrinsics();
  DepthCorrectedSource corrected(std::make_unique<MemorySource>(frames, k, "three"), 1.031);
  EXPECT_EQ(corrected.size(), 3);
  EXPECT_THAT(corrected.describe(), HasSubstr("depth / 1.031"));
  int n = 0;
  while (auto f = corrected.next()) {
    EXPECT_LT(cv::norm(f->depth_m, frames[n].depth_m / 1.031, cv::NORM_INF), 1e-6) << n;
    EXPECT_EQ(cv::norm(f->rgb, frames[n].rgb, cv::NORM_INF), 0.0) << n;
    ++n;
  }
  EXPECT_EQ(n, 3);
  for (const double bad : {0.0, -1.0, 2.1, std::nan("")})
    EXPECT_THAT(error_of([&] { DepthCorrectedSource s(std::make_unique<MemorySource>(frames, k), bad); }),
                HasSubstr("--depth-correction"));
}

}  // namespace
}  // namespace cofusion
