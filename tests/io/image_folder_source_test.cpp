#include "io/image_folder_source.h"

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

// `n` 24x16 frames named without zero padding (img1 .. imgN) so name order != natural order.
std::vector<Frame> write_folder(const fs::path& dir, int n, const std::string& colour_dir = "colour") {
  std::vector<Frame> frames;
  for (int i = 0; i < n; ++i) {
    Frame f = test::make_test_frame(24, 16, i, i / 30.0);
    const std::string name = "img" + std::to_string(i + 1) + ".png";
    test::write_bgr_png(dir / colour_dir / name, f.rgb);
    test::write_png(dir / "depth" / name, test::depth_units(f.depth_m, 1000));
    frames.push_back(f);
  }
  test::write_text(dir / "calibration.txt", "20 21 11.5 7.5 24 16\n");
  return frames;
}

TEST(ImageFolderSource, ReadsPairsInNaturalOrder) {
  const fs::path dir = test::fresh_temp_dir();
  const auto expected = write_folder(dir, 12);
  test::write_text(dir / "colour" / "notes.txt", "not an image");  // ignored
  ImageFolderSource source(dir);
  EXPECT_EQ(source.size(), 12);
  EXPECT_DOUBLE_EQ(source.intrinsics().fy, 21);
  EXPECT_EQ(source.intrinsics().width, 24);
  EXPECT_THAT(source.describe(), HasSubstr("calibration.txt"));
  for (const Frame& e : expected) {
    auto f = source.next();
    ASSERT_TRUE(f);
    EXPECT_EQ(f->index, e.index);
    EXPECT_DOUBLE_EQ(f->timestamp_s, e.index / 30.0);
    EXPECT_EQ(cv::norm(f->rgb, e.rgb, cv::NORM_INF), 0.0) << "frame " << e.index;
    EXPECT_LT(cv::norm(f->depth_m, e.depth_m, cv::NORM_INF), 1e-6) << "frame " << e.index;  // millimetres exact
    EXPECT_TRUE(f->mask.empty());
  }
  EXPECT_FALSE(source.next());
}

TEST(ImageFolderSource, ColorAndRgbFolderNamesMasksAndTimestamps) {
  const fs::path dir = test::fresh_temp_dir();
  write_folder(dir, 3, "color");
  for (int i = 0; i < 3; ++i) {
    cv::Mat mask(16, 24, CV_8UC1, cv::Scalar(0));
    mask(cv::Rect(0, 0, 4, 4)).setTo(i + 1);
    test::write_png(dir / "masks" / ("m" + std::to_string(i) + ".png"), mask);
  }
  test::write_text(dir / "timestamps.txt", "# seconds\n10.0\n10.5\n11.25\n");
  ImageFolderSource source(dir);
  auto f = source.next();
  ASSERT_TRUE(f);
  EXPECT_DOUBLE_EQ(f->timestamp_s, 10.0);
  ASSERT_EQ(f->mask.type(), CV_16UC1);
  EXPECT_EQ(f->mask.at<std::uint16_t>(1, 1), 1);
  f = source.next();
  f = source.next();
  ASSERT_TRUE(f);
  EXPECT_DOUBLE_EQ(f->timestamp_s, 11.25);
  EXPECT_EQ(f->mask.at<std::uint16_t>(1, 1), 3);

  test::write_text(dir / "timestamps.txt", "10.0\n10.5\n");
  const std::string msg = error_of([&] { ImageFolderSource s(dir); });
  EXPECT_THAT(msg, HasSubstr((dir / "timestamps.txt").string()));
  EXPECT_THAT(msg, HasSubstr("2 timestamps for 3 frames"));
}

TEST(ImageFolderSource, FloatDepthInMetresWithInvalidReadingsZeroed) {
  const fs::path dir = test::fresh_temp_dir();
  write_folder(dir, 1, "rgb");
  cv::Mat depth(16, 24, CV_32FC1, cv::Scalar(1.25f));
  depth.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  depth.at<float>(0, 1) = std::numeric_limits<float>::infinity();
  depth.at<float>(0, 2) = -2.0f;
  fs::remove(dir / "depth" / "img1.png");
  test::write_png(dir / "depth" / "img1.exr", depth);
  ImageFolderSource source(dir);
  auto f = source.next();
  ASSERT_TRUE(f);
  EXPECT_EQ(f->depth_m.at<float>(0, 0), 0.0f);
  EXPECT_EQ(f->depth_m.at<float>(0, 1), 0.0f);
  EXPECT_EQ(f->depth_m.at<float>(0, 2), 0.0f);
  EXPECT_FLOAT_EQ(f->depth_m.at<float>(5, 5), 1.25f);  // metres, not divided by the 16-bit scale
}

TEST(ImageFolderSource, DepthScaleOption) {
  const fs::path dir = test::fresh_temp_dir();
  const auto frames = write_folder(dir, 1);
  ImageFolderSourceOptions o;
  o.depth_units_per_metre = 5000;  // the same files read as if in 1/5000 m
  ImageFolderSource source(dir, o);
  auto f = source.next();
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->depth_m.at<float>(3, 4), frames[0].depth_m.at<float>(3, 4) / 5.0f, 1e-6);
}

TEST(ImageFolderSource, MismatchesNameTheFolderOrFile) {
  const fs::path dir = test::fresh_temp_dir();
  write_folder(dir, 3);
  fs::remove(dir / "depth" / "img2.png");
  std::string msg = error_of([&] { ImageFolderSource s(dir); });
  EXPECT_THAT(msg, HasSubstr("3 colour images"));
  EXPECT_THAT(msg, HasSubstr("2 depth images"));
  EXPECT_THAT(msg, HasSubstr((dir / "depth").string()));

  // Same count, wrong size.
  test::write_png(dir / "depth" / "img2.png", cv::Mat(8, 12, CV_16UC1, cv::Scalar(1000)));
  ImageFolderSource source(dir);
  ASSERT_TRUE(source.next());
  msg = error_of([&] { source.next(); });
  EXPECT_THAT(msg, HasSubstr((dir / "depth" / "img2.png").string()));
  EXPECT_THAT(msg, HasSubstr("12x8, expected 24x16"));

  fs::create_directories(dir / "masks");
  test::write_png(dir / "masks" / "a.png", cv::Mat(16, 24, CV_16UC1, cv::Scalar(1)));
  msg = error_of([&] { ImageFolderSource s(dir); });
  EXPECT_THAT(msg, HasSubstr("1 masks"));

  const fs::path no_depth = test::fresh_temp_dir("nodepth");
  fs::create_directories(no_depth / "colour");
  EXPECT_THAT(error_of([&] { ImageFolderSource s(no_depth); }), HasSubstr("no depth/"));
  const fs::path no_colour = test::fresh_temp_dir("nocolour");
  fs::create_directories(no_colour / "depth");
  EXPECT_THAT(error_of([&] { ImageFolderSource s(no_colour); }), HasSubstr("no colour/"));
}

TEST(ImageFolderSource, WithoutCalibrationSaysPrimesense) {
  const fs::path dir = test::fresh_temp_dir();
  const Frame f = test::make_test_frame(640, 480, 0, 0.0);
  test::write_bgr_png(dir / "colour" / "0.png", f.rgb);
  test::write_png(dir / "depth" / "0.png", test::depth_units(f.depth_m, 1000));
  ImageFolderSource source(dir);
  EXPECT_THAT(source.describe(), HasSubstr("primesense default"));
  EXPECT_DOUBLE_EQ(source.intrinsics().fx, 525.0);
  EXPECT_TRUE(source.next());

  // The PrimeSense principal point is far outside 24x16 images: refused, naming the folder.
  const fs::path small = test::fresh_temp_dir("small");
  write_folder(small, 1);
  fs::remove(small / "calibration.txt");
  const std::string msg = error_of([&] { ImageFolderSource s(small); });
  EXPECT_THAT(msg, HasSubstr(small.string()));
  EXPECT_THAT(msg, HasSubstr("implausible intrinsics"));
}

TEST(ListImagesSorted, NaturalOrder) {
  const fs::path dir = test::fresh_temp_dir();
  for (const char* name : {"f10.png", "f9.png", "f0010.jpg", "f100.png", "a.txt"}) test::write_text(dir / name, "x");
  const auto files = list_images_sorted(dir);
  ASSERT_EQ(files.size(), 4u);
  EXPECT_EQ(files[0].filename(), "f9.png");
  EXPECT_EQ(files[1].filename(), "f10.png");
  EXPECT_EQ(files[2].filename(), "f0010.jpg");
  EXPECT_EQ(files[3].filename(), "f100.png");
}

}  // namespace
}  // namespace cofusion
