#include "io/tum_source.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "common/error.h"
#include "io/trajectory_lookup.h"
#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

using test::error_of;

std::string stamp(double t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6f", t);
  return buf;
}

// A TUM folder of `n` 32x24 frames at 30 Hz starting at t0; depth 5 ms after each rgb. Returns the
// frames as written (depth quantised to 1/5000 m).
struct TumFixture {
  fs::path dir;
  std::vector<Frame> frames;
};

// `rgb_extension`: ".png" (lossless) or e.g. ".jpg".
TumFixture write_tum_fixture(int n, bool associations, double t0 = 100.0, const std::string& rgb_extension = ".png") {
  TumFixture fx{test::fresh_temp_dir(), {}};
  std::string rgb_txt = "# color images\n", depth_txt = "# depth maps\n", assoc;
  for (int i = 0; i < n; ++i) {
    const double t = t0 + i / 30.0;
    Frame f = test::make_test_frame(32, 24, i, t);
    const std::string rgb_name = "rgb/" + stamp(t) + rgb_extension, depth_name = "depth/" + stamp(t + 0.005) + ".png";
    test::write_bgr_png(fx.dir / rgb_name, f.rgb);
    test::write_png(fx.dir / depth_name, test::depth_units(f.depth_m, 5000));
    rgb_txt += stamp(t) + " " + rgb_name + "\n";
    depth_txt += stamp(t + 0.005) + " " + depth_name + "\n";
    assoc += stamp(t) + " " + rgb_name + " " + stamp(t + 0.005) + " " + depth_name + "\n";
    fx.frames.push_back(f);
  }
  test::write_text(fx.dir / "rgb.txt", rgb_txt);
  test::write_text(fx.dir / "depth.txt", depth_txt);
  if (associations) test::write_text(fx.dir / "associations.txt", assoc);
  test::write_text(fx.dir / "calibration.txt", "30 30 15.5 11.5\n");
  return fx;
}

void expect_frames_match(TumSource& source, const std::vector<Frame>& expected) {
  for (const Frame& e : expected) {
    auto f = source.next();
    ASSERT_TRUE(f);
    EXPECT_EQ(f->index, e.index);
    EXPECT_NEAR(f->timestamp_s, e.timestamp_s, 1e-6);
    ASSERT_EQ(f->rgb.type(), CV_8UC3);
    ASSERT_EQ(f->depth_m.type(), CV_32FC1);
    EXPECT_EQ(cv::norm(f->rgb, e.rgb, cv::NORM_INF), 0.0) << "frame " << e.index;
    EXPECT_LT(cv::norm(f->depth_m, e.depth_m, cv::NORM_INF), 1e-4) << "frame " << e.index;
  }
  EXPECT_FALSE(source.next());
}

TEST(TumSource, ReadsAssociationsTxt) {
  const auto fx = write_tum_fixture(4, true);
  TumSource source(fx.dir);
  EXPECT_EQ(source.size(), 4);
  EXPECT_EQ(source.intrinsics().width, 32);  // calibration.txt without size: from the first image
  EXPECT_EQ(source.intrinsics().height, 24);
  EXPECT_DOUBLE_EQ(source.intrinsics().fx, 30);
  EXPECT_THAT(source.describe(), HasSubstr("associations.txt"));
  EXPECT_THAT(source.describe(), HasSubstr("calibration.txt"));
  expect_frames_match(source, fx.frames);
}

TEST(TumSource, MatchesRgbAndDepthByTimeWithoutAssociations) {
  auto fx = write_tum_fixture(4, false);
  // An rgb with no depth within 0.02 s, and a depth with no rgb: both are left out.
  const Frame extra = test::make_test_frame(32, 24, 9, 200.0);
  test::write_bgr_png(fx.dir / "rgb/200.000000.png", extra.rgb);
  test::write_png(fx.dir / "depth/300.000000.png", test::depth_units(extra.depth_m, 5000));
  std::ofstream(fx.dir / "rgb.txt", std::ios::app) << "200.000000 rgb/200.000000.png\n";
  std::ofstream(fx.dir / "depth.txt", std::ios::app) << "300.000000 depth/300.000000.png\n";
  TumSource source(fx.dir);
  EXPECT_EQ(source.size(), 4);
  EXPECT_THAT(source.describe(), HasSubstr("matched by time"));
  expect_frames_match(source, fx.frames);
}

TEST(TumAssociate, EachImageUsedOnceClosestFirst) {
  const std::vector<TimedFile> rgb = {{1.000, "a"}, {1.010, "b"}, {2.0, "c"}, {3.0, "d"}};
  const std::vector<TimedFile> depth = {{1.012, "x"}, {2.019, "y"}, {2.9, "z"}};
  const auto pairs = associate_by_time(rgb, depth, 0.02);
  // b-x (2 ms) wins over a-x (12 ms), so a stays unpaired; c-y is 19 ms; d-z is 100 ms: too far.
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].rgb.file, "b");
  EXPECT_EQ(pairs[0].depth.file, "x");
  EXPECT_EQ(pairs[1].rgb.file, "c");
  EXPECT_EQ(pairs[1].depth.file, "y");
}

TEST(TumAssociations, DepthFirstColumnsAreSwapped) {
  const auto dir = test::fresh_temp_dir();
  test::write_text(dir / "a.txt", "# comment\n1.5 depth/1.png 1.49 rgb/1.png\n");
  const auto a = read_tum_associations(dir / "a.txt");
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0].rgb.file, "rgb/1.png");
  EXPECT_DOUBLE_EQ(a[0].rgb.timestamp_s, 1.49);
  test::write_text(dir / "bad.txt", "1.5 rgb/1.png\n");
  EXPECT_THAT(error_of([&] { read_tum_associations(dir / "bad.txt"); }), HasSubstr("bad.txt:1"));
}

TEST(TumSource, GroundTruthInterpolatedOrNearest) {
  auto fx = write_tum_fixture(3, true);
  const double t0 = fx.frames[0].timestamp_s, t1 = fx.frames[1].timestamp_s;
  // Frame 0 between samples 5 ms either side (interpolated); frame 1 only 15 ms after a sample
  // (nearest); frame 2 has no sample within 20 ms.
  test::write_text(fx.dir / "groundtruth.txt",
                   "# timestamp tx ty tz qx qy qz qw\n" + stamp(t0 - 0.005) + " 0 0 0 0 0 0 1\n" + stamp(t0 + 0.005) +
                       " 1 2 0 0 0 0.7071067811865476 0.7071067811865476\n" + stamp(t1 - 0.015) + " 5 5 5 0 0 0 1\n");
  TumSource source(fx.dir);
  EXPECT_TRUE(source.has_groundtruth());
  auto f0 = source.next();
  ASSERT_TRUE(f0 && f0->T_world_camera_gt);
  EXPECT_NEAR(f0->T_world_camera_gt->translation().x(), 0.5, 1e-3);
  EXPECT_NEAR(f0->T_world_camera_gt->translation().y(), 1.0, 1e-3);
  EXPECT_NEAR(Eigen::AngleAxisd(f0->T_world_camera_gt->rotation()).angle(), M_PI / 4, 1e-3);  // half of 90 deg
  auto f1 = source.next();
  ASSERT_TRUE(f1 && f1->T_world_camera_gt);
  EXPECT_NEAR(f1->T_world_camera_gt->translation().z(), 5.0, 1e-9);
  auto f2 = source.next();
  ASSERT_TRUE(f2);
  EXPECT_FALSE(f2->T_world_camera_gt);
}

TEST(TumSource, MasksFolderGivesMasks) {
  auto fx = write_tum_fixture(2, true);
  for (const Frame& f : fx.frames) {
    cv::Mat mask(24, 32, CV_16UC1, cv::Scalar(0));
    mask(cv::Rect(4, 4, 8, 8)).setTo(f.index + 300);  // ids above 255 must survive
    test::write_png(fx.dir / "masks" / (stamp(f.timestamp_s) + ".png"), mask);
  }
  TumSource source(fx.dir);
  EXPECT_THAT(source.describe(), HasSubstr("masks"));
  auto f = source.next();
  ASSERT_TRUE(f);
  ASSERT_EQ(f->mask.type(), CV_16UC1);
  EXPECT_EQ(f->mask.at<std::uint16_t>(5, 5), 300);
  EXPECT_EQ(f->mask.at<std::uint16_t>(20, 20), 0);

  // A missing mask is a bad frame (read past), found when the frame is read.
  fs::remove(fx.dir / "masks" / (stamp(fx.frames[1].timestamp_s) + ".png"));
  EXPECT_THAT(error_of([&] { source.next(); }), HasSubstr(stamp(fx.frames[1].timestamp_s) + ".png"));
}

// masks/<stamp>.png of frame `i` of the fixture.
fs::path mask_file(const TumFixture& fx, int i) {
  return fx.dir / "masks" / (stamp(fx.frames[static_cast<std::size_t>(i)].timestamp_s) + ".png");
}

TEST(TumSource, MasksOf8And16BitsWithAClassTable) {
  auto fx = write_tum_fixture(2, true);
  cv::Mat mask8(24, 32, CV_8UC1, cv::Scalar(0));
  mask8(cv::Rect(0, 0, 4, 4)).setTo(1);
  mask8(cv::Rect(10, 10, 4, 4)).setTo(2);
  test::write_png(mask_file(fx, 0), mask8);
  cv::Mat mask16(24, 32, CV_16UC1, cv::Scalar(0));
  mask16(cv::Rect(4, 4, 8, 8)).setTo(300);
  test::write_png(mask_file(fx, 1), mask16);
  test::write_text(fx.dir / "masks" / "classes.txt",
                   "# id class_name\n1 box\n\n2 can   # a trailing comment\n300 person\n");

  TumSource source(fx.dir);
  EXPECT_THAT(source.describe(), HasSubstr("masks with classes"));
  auto f0 = source.next();
  ASSERT_TRUE(f0);
  ASSERT_EQ(f0->mask.type(), CV_16UC1);
  EXPECT_EQ(f0->mask.at<std::uint16_t>(1, 1), 1);
  EXPECT_EQ(f0->mask.at<std::uint16_t>(11, 11), 2);
  EXPECT_EQ(f0->mask.at<std::uint16_t>(20, 20), 0);
  ASSERT_TRUE(f0->mask_classes);
  const std::map<std::uint16_t, std::string> expected{{1, "box"}, {2, "can"}, {300, "person"}};
  EXPECT_EQ(f0->mask_classes->name_by_id, expected);
  auto f1 = source.next();
  ASSERT_TRUE(f1);
  EXPECT_EQ(f1->mask.at<std::uint16_t>(5, 5), 300);
  EXPECT_EQ(f1->mask_classes.get(), f0->mask_classes.get()) << "the table is read once per source";

  // Without classes.txt the frames carry masks but no table.
  fs::remove(fx.dir / "masks" / "classes.txt");
  TumSource plain(fx.dir);
  EXPECT_THAT(plain.describe(), ::testing::Not(HasSubstr("classes")));
  auto g = plain.next();
  ASSERT_TRUE(g);
  EXPECT_FALSE(g->mask.empty());
  EXPECT_FALSE(g->mask_classes);
}

TEST(TumSource, JpegColourImagesHavePngMasksOfTheSameStem) {
  auto fx = write_tum_fixture(2, true, 100.0, ".jpg");
  for (int i = 0; i < 2; ++i) test::write_png(mask_file(fx, i), cv::Mat(24, 32, CV_8UC1, cv::Scalar(i + 1)));
  TumSource source(fx.dir);
  for (int i = 0; i < 2; ++i) {
    auto f = source.next();
    ASSERT_TRUE(f);
    EXPECT_EQ(f->rgb.type(), CV_8UC3);
    EXPECT_EQ(f->mask.at<std::uint16_t>(3, 3), i + 1);
  }
  // A lossy mask beside the jpg is not taken: the .png is what must exist.
  fs::rename(mask_file(fx, 1), fs::path(mask_file(fx, 1)).replace_extension(".jpg"));
  TumSource again(fx.dir);
  ASSERT_TRUE(again.next());
  EXPECT_THAT(error_of([&] { again.next(); }), HasSubstr(mask_file(fx, 1).string()));
}

TEST(TumSource, BadMasksAndClassTablesNameTheFile) {
  auto fx = write_tum_fixture(2, true);
  const cv::Mat good(24, 32, CV_16UC1, cv::Scalar(1));
  const fs::path mask1 = mask_file(fx, 1);
  test::write_png(mask_file(fx, 0), good);
  // Reads frame 1 after a good frame 0 and returns the error.
  const auto second_frame_error = [&] {
    TumSource source(fx.dir);
    EXPECT_TRUE(source.next());
    return error_of([&] { source.next(); });
  };

  test::write_png(mask1, cv::Mat(12, 16, CV_16UC1, cv::Scalar(1)));
  std::string msg = second_frame_error();
  EXPECT_THAT(msg, HasSubstr(mask1.string()));
  EXPECT_THAT(msg, HasSubstr("16x12, expected 32x24"));

  test::write_png(mask1, cv::Mat(24, 32, CV_8UC3, cv::Scalar(1, 1, 1)));
  msg = second_frame_error();
  EXPECT_THAT(msg, HasSubstr(mask1.string()));
  EXPECT_THAT(msg, HasSubstr("8UC3"));

  test::write_text(mask1, "not a png");
  msg = second_frame_error();
  EXPECT_THAT(msg, HasSubstr(mask1.string()));
  EXPECT_THAT(msg, HasSubstr("cannot be decoded"));

  // An id the class table does not list: the mask file and the id are named.
  cv::Mat unlisted = good.clone();
  unlisted.at<std::uint16_t>(5, 7) = 7;
  test::write_png(mask1, unlisted);
  const fs::path classes = fx.dir / "masks" / "classes.txt";
  test::write_text(classes, "1 box\n");
  msg = second_frame_error();
  EXPECT_THAT(msg, HasSubstr(mask1.string()));
  EXPECT_THAT(msg, HasSubstr("id 7"));
  EXPECT_THAT(msg, HasSubstr(classes.string()));

  // A class table line that does not parse fails when the source opens.
  test::write_text(classes, "# ok\n1 box\ntwo can\n");
  msg = error_of([&] { TumSource s(fx.dir); });
  EXPECT_THAT(msg, HasSubstr(classes.string() + ":3"));
  EXPECT_THAT(msg, HasSubstr("'two'"));

  // A frame without its mask is a bad frame naming the mask.
  fs::remove(classes);
  fs::remove(mask1);
  msg = second_frame_error();
  EXPECT_THAT(msg, HasSubstr(mask1.string()));
  EXPECT_THAT(msg, HasSubstr("does not exist"));
}

TEST(TumSource, IntrinsicsOptionAndDefaults) {
  const auto fx = write_tum_fixture(1, true);
  {
    TumSourceOptions o;
    o.intrinsics = "40,41,16,12";
    TumSource source(fx.dir, o);
    EXPECT_DOUBLE_EQ(source.intrinsics().fy, 41);
    EXPECT_EQ(source.intrinsics().width, 32);
  }
  fs::remove(fx.dir / "calibration.txt");
  // No option, no calibration.txt, no fr1/2/3 in the path: primesense, and it says so. Its
  // 640x480 then contradicts the 32x24 images, which fails naming the image.
  TumSource source(fx.dir);
  EXPECT_THAT(source.describe(), HasSubstr("primesense default"));
  const std::string msg = error_of([&] { source.next(); });
  EXPECT_THAT(msg, HasSubstr(stamp(fx.frames[0].timestamp_s) + ".png"));
  EXPECT_THAT(msg, HasSubstr("32x24, expected 640x480"));
}

// The fr1/fr2 Kinects read depth a few percent long; the TUM benchmark lists the factor beside
// their intrinsics. A folder of such a camera divides by it, others do not, and the option wins.
TEST(TumSource, DepthCorrectionOfTumCameras) {
  const auto fx = write_tum_fixture(2, true);
  {
    TumSource source(fx.dir);  // calibration.txt: not a TUM camera
    EXPECT_EQ(source.depth_correction(), 1.0);
    EXPECT_THAT(source.describe(), ::testing::Not(HasSubstr("depth /")));
    EXPECT_THAT(source.describe(), ::testing::Not(HasSubstr("rolling shutter")));
    const auto f = source.next();
    ASSERT_TRUE(f);
    EXPECT_EQ(f->colour_readout_s, 0.0);
  }
  {
    TumSourceOptions o;
    o.depth_correction = 1.25;
    TumSource source(fx.dir, o);
    EXPECT_EQ(source.depth_correction(), 1.25);
    EXPECT_THAT(source.describe(), HasSubstr("depth / 1.250 (--depth-correction)"));
    auto f = source.next();
    ASSERT_TRUE(f);
    const cv::Mat expected = fx.frames[0].depth_m / 1.25;
    EXPECT_LT(cv::norm(f->depth_m, expected, cv::NORM_INF), 1e-4);
    EXPECT_EQ(cv::countNonZero(f->depth_m), cv::countNonZero(fx.frames[0].depth_m));  // no reading stays 0
  }
  for (const double bad : {0.0, 0.3, 2.5, std::nan("")}) {
    TumSourceOptions o;
    o.depth_correction = bad;
    const std::string msg = error_of([&] { TumSource s(fx.dir, o); });
    EXPECT_THAT(msg, HasSubstr(fx.dir.string()));
    EXPECT_THAT(msg, HasSubstr("--depth-correction"));
  }
  {
    TumSourceOptions o;
    o.intrinsics = "fr1";  // a TUM camera named on the command line
    TumSource source(fx.dir, o);
    EXPECT_EQ(source.depth_correction(), 1.035);
    EXPECT_THAT(source.describe(), HasSubstr("depth / 1.035 (fr1 depth correction)"));
    // Its colour camera's rolling shutter travels with every frame (slam::RollingShutterParams).
    EXPECT_THAT(source.describe(), HasSubstr("colour rolling shutter 20 ms (fr1)"));
    EXPECT_EQ(source.colour_readout_s(), 0.02);
  }
  // A folder named after a TUM camera, without calibration.txt: the guessed preset brings its own.
  const fs::path fr2_dir = fx.dir.parent_path() / (fx.dir.filename().string() + "_fr2_desk");
  fs::rename(fx.dir, fr2_dir);
  fs::remove(fr2_dir / "calibration.txt");
  {
    TumSource source(fr2_dir);
    EXPECT_EQ(source.depth_correction(), 1.031);
    EXPECT_THAT(source.describe(), HasSubstr("depth / 1.031 (fr2 depth correction)"));
    EXPECT_THAT(source.describe(), ::testing::Not(HasSubstr("rolling shutter")));  // fr1's only
    EXPECT_EQ(source.colour_readout_s(), 0.0);
    TumSourceOptions o;
    o.depth_correction = 1.0;  // switched off
    TumSource raw(fr2_dir, o);
    EXPECT_EQ(raw.depth_correction(), 1.0);
  }
  fs::remove_all(fr2_dir);
}

TEST(TumSource, BadInputNamesTheFile) {
  EXPECT_THAT(error_of([] { TumSource s("/nonexistent/tum_folder"); }), HasSubstr("/nonexistent/tum_folder"));
  {
    const auto dir = test::fresh_temp_dir();
    test::write_text(dir / "rgb.txt", "1.0 rgb/1.png\n");
    EXPECT_THAT(error_of([&] { TumSource s(dir); }), HasSubstr("depth.txt"));
    test::write_text(dir / "depth.txt", "1.0 depth/1.png\nnot-a-time depth/2.png\n");
    EXPECT_THAT(error_of([&] { TumSource s(dir); }), HasSubstr("depth.txt:2"));
  }
  {
    auto fx = write_tum_fixture(2, true);
    const fs::path depth1 = fx.dir / ("depth/" + stamp(fx.frames[1].timestamp_s + 0.005) + ".png");
    fs::remove(depth1);
    {
      TumSource s(fx.dir);
      ASSERT_TRUE(s.next());
      EXPECT_THAT(error_of([&] { s.next(); }), HasSubstr(depth1.string()));
    }
    // Depth of the wrong size, then depth with 8 bits.
    test::write_png(depth1, cv::Mat(12, 16, CV_16UC1, cv::Scalar(5000)));
    TumSource s(fx.dir);
    ASSERT_TRUE(s.next());
    std::string msg = error_of([&] { s.next(); });
    EXPECT_THAT(msg, HasSubstr(depth1.string()));
    EXPECT_THAT(msg, HasSubstr("16x12"));
    test::write_png(depth1, cv::Mat(24, 32, CV_8UC1, cv::Scalar(5)));
    TumSource s2(fx.dir);
    ASSERT_TRUE(s2.next());
    msg = error_of([&] { s2.next(); });
    EXPECT_THAT(msg, HasSubstr(depth1.string()));
    EXPECT_THAT(msg, HasSubstr("8UC1"));
    // A corrupt colour file.
    const fs::path rgb0 = fx.dir / ("rgb/" + stamp(fx.frames[0].timestamp_s) + ".png");
    test::write_text(rgb0, "not a png");
    // (The first colour image is read when the source opens, for the image size.)
    EXPECT_THAT(error_of([&] { TumSource s3(fx.dir); }), HasSubstr(rgb0.string()));
  }
  {
    // Not one listed image exists: the wrong folder, said when it opens.
    auto fx = write_tum_fixture(2, true);
    fs::remove_all(fx.dir / "rgb");
    EXPECT_THAT(error_of([&] { TumSource s(fx.dir); }), HasSubstr("not one of its 2 rgb/depth pairs"));
  }
  {
    auto fx = write_tum_fixture(1, true);
    test::write_text(fx.dir / "associations.txt", "");
    EXPECT_THAT(error_of([&] { TumSource s(fx.dir); }), HasSubstr("no rgb/depth pairs"));
  }
}

// A frame that cannot be read is a BadFrame naming the frame and the file; the source has moved
// past it and the next call reads the frame after.
TEST(TumSource, BadFrameIsSkippedAndReadingGoesOn) {
  auto fx = write_tum_fixture(4, true);
  const fs::path rgb1 = fx.dir / ("rgb/" + stamp(fx.frames[1].timestamp_s) + ".png");
  const fs::path depth2 = fx.dir / ("depth/" + stamp(fx.frames[2].timestamp_s + 0.005) + ".png");
  test::write_text(rgb1, "not a png");
  fs::remove(depth2);
  TumSource source(fx.dir);
  ASSERT_EQ(source.next()->index, 0);
  for (const auto& [index, file] : {std::pair{1, rgb1}, std::pair{2, depth2}}) {
    try {
      source.next();
      ADD_FAILURE() << "frame " << index << " read without an error";
    } catch (const BadFrame& e) {
      EXPECT_EQ(e.frame_index(), index);
      EXPECT_THAT(e.reason(), HasSubstr(file.string()));
    }
  }
  const auto last = source.next();
  ASSERT_TRUE(last);
  EXPECT_EQ(last->index, 3);
  EXPECT_FALSE(source.next());
}

// --- The real recordings -------------------------------------------------------------------

struct DepthStats {
  double valid_fraction = 0, median_m = 0, max_m = 0;
};
DepthStats depth_stats(const cv::Mat& depth_m) {
  std::vector<float> v;
  for (int y = 0; y < depth_m.rows; ++y)
    for (int x = 0; x < depth_m.cols; ++x)
      if (const float d = depth_m.at<float>(y, x); d > 0) v.push_back(d);
  DepthStats s;
  if (v.empty()) return s;
  s.valid_fraction = static_cast<double>(v.size()) / static_cast<double>(depth_m.total());
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  s.median_m = v[v.size() / 2];
  s.max_m = *std::max_element(v.begin(), v.end());
  return s;
}

TEST(TumSource, RealFr2Desk50) {
  const auto dir = test::data_dir("tum_fr2_desk_50");
  if (!dir) GTEST_SKIP() << "tum_fr2_desk_50 not found (set COFUSION_DATA to the shared data folder)";
  TumSource source(*dir);
  EXPECT_EQ(source.size(), 50);
  const Intrinsics k = source.intrinsics();
  EXPECT_DOUBLE_EQ(k.fx, 520.9);
  EXPECT_DOUBLE_EQ(k.fy, 521.0);
  EXPECT_DOUBLE_EQ(k.cx, 325.1);
  EXPECT_DOUBLE_EQ(k.cy, 249.7);
  EXPECT_THAT(source.describe(), HasSubstr("fr2 preset (guessed from the path)"));
  EXPECT_THAT(source.describe(), HasSubstr("ground truth"));
  EXPECT_EQ(source.depth_correction(), 1.031);

  const Trajectory gt = read_tum_trajectory(*dir / "groundtruth.txt");
  int n = 0;
  double last_t = 0;
  while (auto f = source.next()) {
    EXPECT_EQ(f->index, n);
    EXPECT_EQ(f->rgb.size(), cv::Size(640, 480));
    EXPECT_EQ(f->depth_m.size(), cv::Size(640, 480));
    EXPECT_TRUE(f->mask.empty());
    if (n > 0) {
      EXPECT_GT(f->timestamp_s, last_t);
    }
    last_t = f->timestamp_s;
    if (n == 0) {
      // The recorded 16-bit depth, divided by the fr2 correction.
      std::string first_depth;
      std::ifstream assoc(*dir / "associations.txt");
      for (std::string line; std::getline(assoc, line) && first_depth.empty();) {
        std::istringstream ss(line);
        std::string t_rgb, rgb, t_depth;
        if (line.empty() || line[0] == '#' || !(ss >> t_rgb >> rgb >> t_depth >> first_depth)) first_depth.clear();
      }
      const cv::Mat raw = cv::imread((*dir / first_depth).string(), cv::IMREAD_UNCHANGED);
      ASSERT_EQ(raw.type(), CV_16UC1) << first_depth;
      cv::Mat expected;
      raw.convertTo(expected, CV_32F, 1.0 / (5000.0 * 1.031));
      EXPECT_LT(cv::norm(f->depth_m, expected, cv::NORM_INF), 1e-5);
    }
    const DepthStats s = depth_stats(f->depth_m);
    EXPECT_GT(s.valid_fraction, 0.5) << "frame " << n;
    EXPECT_GT(s.median_m, 0.5) << "frame " << n;  // a desk seen from about 1-2 m
    EXPECT_LT(s.median_m, 4.0) << "frame " << n;
    EXPECT_LE(s.max_m, 65535.0 / 5000) << "frame " << n;  // the 16-bit range
    ASSERT_TRUE(f->T_world_camera_gt) << "frame " << n;
    const auto expected = pose_at(gt, f->timestamp_s, 0.02);
    ASSERT_TRUE(expected);
    EXPECT_LT((f->T_world_camera_gt->matrix() - expected->matrix()).norm(), 1e-9);
    ++n;
  }
  EXPECT_EQ(n, 50);
  EXPECT_NEAR(last_t, 1311868166.0, 1.0);
}

TEST(TumSource, RealFr1Rpy200) {
  const auto dir = test::data_dir("tum_fr1_rpy_200");
  if (!dir) GTEST_SKIP() << "tum_fr1_rpy_200 not found (set COFUSION_DATA to the shared data folder)";
  TumSource source(*dir);
  EXPECT_EQ(source.size(), 200);
  EXPECT_DOUBLE_EQ(source.intrinsics().fx, 517.3);
  EXPECT_DOUBLE_EQ(source.intrinsics().cy, 255.3);
  EXPECT_THAT(source.describe(), HasSubstr("fr1 preset"));
  // The first frames only: every file was checked to exist when the source opened.
  for (int i = 0; i < 5; ++i) {
    auto f = source.next();
    ASSERT_TRUE(f);
    const DepthStats s = depth_stats(f->depth_m);
    EXPECT_GT(s.valid_fraction, 0.3);
    EXPECT_GT(s.median_m, 0.3);
    EXPECT_LE(s.max_m, 65535.0 / 5000);
    EXPECT_TRUE(f->T_world_camera_gt);
  }
}

TEST(TumSource, RealFr2WithoutAssociationsMatchesTheShippedOnes) {
  const auto dir = test::data_dir("tum_fr2_desk_50");
  if (!dir) GTEST_SKIP() << "tum_fr2_desk_50 not found";
  const auto shipped = read_tum_associations(*dir / "associations.txt");
  const auto matched =
      associate_by_time(read_tum_file_list(*dir / "rgb.txt"), read_tum_file_list(*dir / "depth.txt"), 0.02);
  ASSERT_EQ(matched.size(), shipped.size());
  for (std::size_t i = 0; i < shipped.size(); ++i) {
    EXPECT_EQ(matched[i].rgb.file, shipped[i].rgb.file);
    EXPECT_EQ(matched[i].depth.file, shipped[i].depth.file);
  }
}

}  // namespace
}  // namespace cofusion
