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

TEST(ImageFolderSource, MasksWithAClassTable) {
  const fs::path dir = test::fresh_temp_dir();
  write_folder(dir, 2);
  cv::Mat mask8(16, 24, CV_8UC1, cv::Scalar(0));
  mask8(cv::Rect(0, 0, 4, 4)).setTo(3);
  test::write_png(dir / "masks" / "m1.png", mask8);
  cv::Mat mask16(16, 24, CV_16UC1, cv::Scalar(0));
  mask16(cv::Rect(0, 0, 4, 4)).setTo(1000);
  test::write_png(dir / "masks" / "m2.png", mask16);
  test::write_text(dir / "masks" / "classes.txt", "# instance classes\n3 cup\n1000 teddy_bear\n");

  ImageFolderSource source(dir);
  EXPECT_EQ(source.size(), 2) << "classes.txt is not a mask";
  EXPECT_THAT(source.describe(), HasSubstr("masks with classes"));
  auto f0 = source.next();
  ASSERT_TRUE(f0);
  EXPECT_EQ(f0->mask.at<std::uint16_t>(1, 1), 3);
  ASSERT_TRUE(f0->mask_classes);
  ASSERT_NE(f0->mask_classes->find(3), nullptr);
  EXPECT_EQ(*f0->mask_classes->find(3), "cup");
  auto f1 = source.next();
  ASSERT_TRUE(f1);
  EXPECT_EQ(f1->mask.at<std::uint16_t>(1, 1), 1000);
  EXPECT_EQ(*f1->mask_classes->find(1000), "teddy_bear");
  EXPECT_EQ(f1->mask_classes.get(), f0->mask_classes.get());
}

TEST(ImageFolderSource, BadMasksNameTheFile) {
  const fs::path dir = test::fresh_temp_dir();
  write_folder(dir, 2);
  test::write_png(dir / "masks" / "m1.png", cv::Mat(16, 24, CV_8UC1, cv::Scalar(1)));
  const fs::path mask2 = dir / "masks" / "m2.png";
  cv::Mat unlisted(16, 24, CV_8UC1, cv::Scalar(1));
  unlisted.at<std::uint8_t>(2, 3) = 9;
  test::write_png(mask2, unlisted);
  const fs::path classes = dir / "masks" / "classes.txt";
  test::write_text(classes, "1 box\n");
  const auto second_frame_error = [&] {
    ImageFolderSource source(dir);
    EXPECT_TRUE(source.next());
    return error_of([&] { source.next(); });
  };
  std::string msg = second_frame_error();
  EXPECT_THAT(msg, HasSubstr(mask2.string()));
  EXPECT_THAT(msg, HasSubstr("id 9"));

  test::write_png(mask2, cv::Mat(16, 24, CV_16UC3, cv::Scalar(1, 1, 1)));
  msg = second_frame_error();
  EXPECT_THAT(msg, HasSubstr(mask2.string()));
  EXPECT_THAT(msg, HasSubstr("16UC3"));

  test::write_png(mask2, cv::Mat(8, 12, CV_8UC1, cv::Scalar(1)));
  msg = second_frame_error();
  EXPECT_THAT(msg, HasSubstr(mask2.string()));
  EXPECT_THAT(msg, HasSubstr("12x8, expected 24x16"));

  // Masks must be lossless: a JPEG's ids are not what was stored.
  fs::remove(mask2);
  const fs::path jpeg = dir / "masks" / "m2.jpg";
  cv::imwrite(jpeg.string(), cv::Mat(16, 24, CV_8UC1, cv::Scalar(1)));
  msg = second_frame_error();
  EXPECT_THAT(msg, HasSubstr(jpeg.string()));
  EXPECT_THAT(msg, HasSubstr("lossless"));
  fs::remove(jpeg);

  // One mask too few; a class line with a third word.
  msg = error_of([&] { ImageFolderSource s(dir); });
  EXPECT_THAT(msg, HasSubstr("1 masks"));
  test::write_png(mask2, cv::Mat(16, 24, CV_8UC1, cv::Scalar(1)));
  test::write_text(classes, "1 box extra\n");
  msg = error_of([&] { ImageFolderSource s(dir); });
  EXPECT_THAT(msg, HasSubstr(classes.string() + ":1"));
  EXPECT_THAT(msg, HasSubstr("expected 'id class_name'"));
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
