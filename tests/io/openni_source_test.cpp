#include "io/openni_source.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>

#include "common/error.h"
#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

using test::error_of;

TEST(OpenNiSource, Reads3djTestRecording) {
  const auto path = test::data_dir("oni/3dj_test.oni");
  if (!path) GTEST_SKIP() << "oni/3dj_test.oni not found (set COFUSION_DATA to the shared data folder)";
  auto source = OpenNiSource::open_recording(*path);
  EXPECT_EQ(source->size(), 12);
  const Intrinsics k = source->intrinsics();
  EXPECT_EQ(k.width, 640);
  EXPECT_EQ(k.height, 480);
  EXPECT_DOUBLE_EQ(k.cx, 319.5);
  EXPECT_DOUBLE_EQ(k.cy, 239.5);
  // From the depth stream's field of view (about 58 x 45 degrees, a Kinect-class sensor).
  EXPECT_GT(k.fx, 500);
  EXPECT_LT(k.fx, 620);
  EXPECT_GT(k.fy, 500);
  EXPECT_LT(k.fy, 620);
  EXPECT_THAT(source->describe(), HasSubstr("field of view"));
  EXPECT_THAT(source->describe(), HasSubstr("12 frames"));

  int n = 0;
  double last_t = -1;
  while (auto f = source->next()) {
    EXPECT_EQ(f->index, n);
    ASSERT_EQ(f->depth_m.type(), CV_32FC1);
    ASSERT_EQ(f->rgb.type(), CV_8UC3);
    EXPECT_EQ(f->depth_m.size(), cv::Size(640, 480));
    EXPECT_EQ(f->rgb.size(), cv::Size(640, 480));
    const cv::Mat valid = f->depth_m > 0.0f;
    EXPECT_GT(cv::countNonZero(valid), 640 * 480 / 2) << "frame " << n;
    EXPECT_NEAR(cv::mean(f->depth_m, valid)[0], 2.6, 0.1) << "frame " << n;  // metres, not millimetres
    EXPECT_GT(cv::mean(f->rgb)[0] + cv::mean(f->rgb)[1] + cv::mean(f->rgb)[2], 30.0) << "frame " << n;
    EXPECT_GT(f->timestamp_s, last_t);
    last_t = f->timestamp_s;
    ++n;
  }
  EXPECT_EQ(n, 12);
  EXPECT_FALSE(source->next());
}

TEST(OpenNiSource, IntrinsicsOptionOverridesFieldOfView) {
  const auto path = test::data_dir("oni/3dj_test.oni");
  if (!path) GTEST_SKIP() << "oni/3dj_test.oni not found";
  OpenNiSourceOptions o;
  o.intrinsics = "primesense";
  auto source = OpenNiSource::open_recording(*path, o);
  EXPECT_DOUBLE_EQ(source->intrinsics().fx, 525.0);
  o.intrinsics = "500,500,160,120,320,240";
  const std::string msg = error_of([&] { OpenNiSource::open_recording(*path, o); });
  EXPECT_THAT(msg, HasSubstr("320x240"));
  EXPECT_THAT(msg, HasSubstr("640x480"));
}

TEST(OpenNiSource, EmptyRecordingFailsNamingTheFile) {
  const auto path = test::data_dir("oni/empty_recording.oni");
  if (!path) GTEST_SKIP() << "oni/empty_recording.oni not found";
  const std::string msg = error_of([&] { OpenNiSource::open_recording(*path); });
  EXPECT_THAT(msg, HasSubstr(path->string()));
  EXPECT_THAT(msg, HasSubstr("cannot open the recording"));
}

TEST(OpenNiSource, MissingOrForeignFileFailsNamingTheFile) {
  const fs::path dir = test::fresh_temp_dir();
  EXPECT_THAT(error_of([&] { OpenNiSource::open_recording(dir / "missing.oni"); }),
              HasSubstr((dir / "missing.oni").string()));
  test::write_text(dir / "text.oni", "this is not a recording");
  EXPECT_THAT(error_of([&] { OpenNiSource::open_recording(dir / "text.oni"); }), HasSubstr((dir / "text.oni").string()));
}

}  // namespace
}  // namespace cofusion
