#include "io/intrinsics_option.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/error.h"
#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
using ::testing::HasSubstr;

using test::error_of;

TEST(IntrinsicsPreset, TumAndPrimesenseValues) {
  const auto fr1 = intrinsics_preset("fr1");
  ASSERT_TRUE(fr1);
  EXPECT_DOUBLE_EQ(fr1->fx, 517.3);
  EXPECT_DOUBLE_EQ(fr1->fy, 516.5);
  EXPECT_DOUBLE_EQ(fr1->cx, 318.6);
  EXPECT_DOUBLE_EQ(fr1->cy, 255.3);
  const auto fr2 = intrinsics_preset("freiburg2");
  ASSERT_TRUE(fr2);
  EXPECT_DOUBLE_EQ(fr2->fx, 520.9);
  EXPECT_DOUBLE_EQ(fr2->cy, 249.7);
  const auto fr3 = intrinsics_preset("FR3");
  ASSERT_TRUE(fr3);
  EXPECT_DOUBLE_EQ(fr3->fy, 539.2);
  const auto ps = intrinsics_preset("primesense");
  ASSERT_TRUE(ps);
  EXPECT_DOUBLE_EQ(ps->cx, 319.5);
  EXPECT_EQ(ps->width, 640);
  EXPECT_EQ(ps->height, 480);
  EXPECT_FALSE(intrinsics_preset("fr4"));
}

TEST(IntrinsicsPreset, TumDepthCorrections) {
  EXPECT_EQ(tum_depth_correction("fr1"), 1.035);
  EXPECT_EQ(tum_depth_correction("freiburg2"), 1.031);
  EXPECT_EQ(tum_depth_correction("FR3"), 1.0);
  EXPECT_FALSE(tum_depth_correction("primesense"));
  EXPECT_FALSE(tum_depth_correction("fr4"));
}

TEST(IntrinsicsPreset, TumColourRollingShutter) {
  EXPECT_EQ(tum_colour_readout_s("fr1"), 0.02);
  EXPECT_EQ(tum_colour_readout_s("Freiburg1"), 0.02);
  EXPECT_EQ(tum_colour_readout_s("fr2"), 0.0);
  EXPECT_EQ(tum_colour_readout_s("fr3"), 0.0);
  EXPECT_EQ(tum_colour_readout_s("primesense"), 0.0);
}

TEST(IntrinsicsOption, FourNumbersLeaveSizeToTheImages) {
  const auto c = parse_intrinsics_option("500, 501,300.5,200");
  EXPECT_FALSE(c.size_known);
  EXPECT_DOUBLE_EQ(c.intrinsics.fx, 500);
  EXPECT_DOUBLE_EQ(c.intrinsics.fy, 501);
  EXPECT_DOUBLE_EQ(c.intrinsics.cx, 300.5);
  EXPECT_DOUBLE_EQ(c.intrinsics.cy, 200);
}

TEST(IntrinsicsOption, SixNumbersGiveTheSize) {
  const auto c = parse_intrinsics_option("100,100,39.5,29.5,80,60");
  EXPECT_TRUE(c.size_known);
  EXPECT_EQ(c.intrinsics.width, 80);
  EXPECT_EQ(c.intrinsics.height, 60);
}

TEST(IntrinsicsOption, PresetName) {
  const auto c = parse_intrinsics_option("fr2");
  EXPECT_TRUE(c.size_known);
  EXPECT_DOUBLE_EQ(c.intrinsics.fx, 520.9);
  EXPECT_THAT(c.origin, HasSubstr("fr2"));
  EXPECT_EQ(c.tum_preset, "fr2");
  EXPECT_EQ(parse_intrinsics_option("Freiburg1").tum_preset, "fr1");
  EXPECT_EQ(parse_intrinsics_option("primesense").tum_preset, "");
  EXPECT_EQ(parse_intrinsics_option("500,500,320,240").tum_preset, "");
}

TEST(IntrinsicsOption, CalibrationFile) {
  const auto dir = test::fresh_temp_dir();
  test::write_text(dir / "cam.txt", "# fx fy cx cy w h\n528 529 320 240 640 480\n");
  const auto c = parse_intrinsics_option((dir / "cam.txt").string());
  EXPECT_TRUE(c.size_known);
  EXPECT_DOUBLE_EQ(c.intrinsics.fy, 529);
  EXPECT_THAT(c.origin, HasSubstr("cam.txt"));
}

TEST(IntrinsicsOption, RejectsGarbageQuotingTheOption) {
  EXPECT_THAT(error_of([] { parse_intrinsics_option("wide-angle"); }), HasSubstr("--intrinsics 'wide-angle'"));
  EXPECT_THAT(error_of([] { parse_intrinsics_option("500,500,x,240"); }), HasSubstr("'x' is not a number"));
  EXPECT_THAT(error_of([] { parse_intrinsics_option("500,500,320"); }), HasSubstr("expected 4 numbers"));
  EXPECT_THAT(error_of([] { parse_intrinsics_option("-500,500,320,240"); }), HasSubstr("implausible intrinsics"));
  EXPECT_THAT(error_of([] { parse_intrinsics_option("nan,500,320,240"); }), HasSubstr("'nan' is not a number"));
  EXPECT_THAT(error_of([] { parse_intrinsics_option("500,500,320,240,640.5,480"); }), HasSubstr("positive integers"));
}

TEST(CalibrationFile, ErrorsNameTheFile) {
  const auto dir = test::fresh_temp_dir();
  EXPECT_THAT(error_of([&] { read_calibration_file(dir / "missing.txt"); }), HasSubstr("missing.txt"));
  test::write_text(dir / "bad.txt", "525 525 abc 240\n");
  EXPECT_THAT(error_of([&] { read_calibration_file(dir / "bad.txt"); }), HasSubstr("bad.txt"));
  test::write_text(dir / "short.txt", "525 525\n");
  const std::string msg = error_of([&] { read_calibration_file(dir / "short.txt"); });
  EXPECT_THAT(msg, HasSubstr("short.txt"));
  EXPECT_THAT(msg, HasSubstr("got 2"));
  test::write_text(dir / "far.txt", "525 525 5000 240 640 480\n");  // principal point far outside
  EXPECT_THAT(error_of([&] { read_calibration_file(dir / "far.txt"); }), HasSubstr("implausible"));
}

TEST(GuessTumPreset, FromFolderNames) {
  EXPECT_EQ(guess_tum_preset("/data/rgbd_dataset_freiburg1_rpy"), "fr1");
  EXPECT_EQ(guess_tum_preset("/data/tum_fr2_desk_50"), "fr2");
  EXPECT_EQ(guess_tum_preset("/data/fr3/walking_xyz"), "fr3");
  EXPECT_EQ(guess_tum_preset("/data/freiburg1/../fr2_desk"), "fr2");  // normalised: deepest counts
  EXPECT_FALSE(guess_tum_preset("/data/fr23_scan"));
  EXPECT_FALSE(guess_tum_preset("/data/xfr1"));
  EXPECT_FALSE(guess_tum_preset("/data/frames"));
}

}  // namespace
}  // namespace cofusion
