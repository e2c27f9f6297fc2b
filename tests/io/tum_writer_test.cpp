#include "io/tum_writer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>

#include "common/error.h"
#include "io/image_io.h"
#include "io/klg.h"
#include "io/source_adaptors.h"
#include "io/tum_source.h"
#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

using test::error_of;

Intrinsics small_intrinsics() {
  Intrinsics k;
  k.fx = 31.5;
  k.fy = 32.25;
  k.cx = 15.5;
  k.cy = 11.75;
  k.width = 32;
  k.height = 24;
  return k;
}

std::vector<Frame> frames_with_gt_and_masks(int n) {
  std::vector<Frame> frames;
  for (int i = 0; i < n; ++i) {
    Frame f = test::make_test_frame(32, 24, i, 5.0 + i / 30.0);
    f.depth_m.at<float>(0, 1) = 0.1234f;  // not a whole number of 1/5000 m: quantised on writing
    f.mask = cv::Mat(24, 32, CV_16UC1, cv::Scalar(0));
    f.mask(cv::Rect(2, 2, 5, 5)).setTo(1000 + i);
    Pose T = Pose::Identity();
    T.translate(Eigen::Vector3d(0.1 * i, -0.2, 1.5));
    T.rotate(Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d(0.3, 1, 0).normalized()));
    f.T_world_camera_gt = T;
    frames.push_back(f);
  }
  return frames;
}

TEST(TumWriter, RoundTripThroughTumSource) {
  const auto frames = frames_with_gt_and_masks(4);
  const fs::path dir = test::fresh_temp_dir() / "out";
  MemorySource source(frames, small_intrinsics());
  EXPECT_EQ(write_tum_folder(source, dir), 4);
  for (const char* name : {"rgb.txt", "depth.txt", "associations.txt", "groundtruth.txt", "calibration.txt"})
    EXPECT_TRUE(fs::is_regular_file(dir / name)) << name;

  TumSource back(dir);
  EXPECT_EQ(back.size(), 4);
  EXPECT_DOUBLE_EQ(back.intrinsics().fx, 31.5);  // calibration.txt
  EXPECT_DOUBLE_EQ(back.intrinsics().cy, 11.75);
  EXPECT_EQ(back.intrinsics().width, 32);
  for (const Frame& e : frames) {
    auto f = back.next();
    ASSERT_TRUE(f);
    EXPECT_NEAR(f->timestamp_s, e.timestamp_s, 1e-6);
    EXPECT_EQ(cv::norm(f->rgb, e.rgb, cv::NORM_INF), 0.0);
    // Exact in the file's unit (1/5000 m); at most half a unit from the written metres.
    EXPECT_EQ(cv::norm(depth_to_u16(f->depth_m, 5000), depth_to_u16(e.depth_m, 5000), cv::NORM_INF), 0.0);
    EXPECT_LE(cv::norm(f->depth_m, e.depth_m, cv::NORM_INF), 0.5 / 5000 + 1e-7);
    EXPECT_EQ(cv::norm(f->mask, e.mask, cv::NORM_INF), 0.0);
    ASSERT_TRUE(f->T_world_camera_gt);
    EXPECT_LT((f->T_world_camera_gt->matrix() - e.T_world_camera_gt->matrix()).norm(), 1e-6);
  }
  EXPECT_FALSE(back.next());

  // The same folder read without associations.txt pairs the same files.
  fs::remove(dir / "associations.txt");
  TumSource matched(dir);
  EXPECT_EQ(matched.size(), 4);
}

TEST(TumWriter, ClassTableOfTheMasksRoundTrips) {
  auto frames = frames_with_gt_and_masks(3);
  auto classes = std::make_shared<InstanceClasses>();
  classes->name_by_id = {{1000, "box"}, {1001, "can"}, {1002, "ball"}};
  for (Frame& f : frames) f.mask_classes = classes;
  const fs::path dir = test::fresh_temp_dir() / "out";
  MemorySource source(frames, small_intrinsics());
  EXPECT_EQ(write_tum_folder(source, dir), 3);
  ASSERT_TRUE(fs::is_regular_file(dir / "masks" / "classes.txt"));
  EXPECT_EQ(read_instance_classes(dir / "masks" / "classes.txt").name_by_id, classes->name_by_id);
  TumSource back(dir);
  auto f = back.next();
  ASSERT_TRUE(f);
  ASSERT_TRUE(f->mask_classes);
  EXPECT_EQ(f->mask_classes->name_by_id, classes->name_by_id);

  // Frames without a table give no classes.txt; a frame whose table differs is rejected.
  const fs::path plain = test::fresh_temp_dir() / "plain";
  MemorySource no_tables(frames_with_gt_and_masks(2), small_intrinsics());
  write_tum_folder(no_tables, plain);
  EXPECT_FALSE(fs::exists(plain / "masks" / "classes.txt"));
  TumFolderWriter writer(test::fresh_temp_dir() / "mixed", small_intrinsics());
  writer.write(frames[0]);
  auto other = std::make_shared<InstanceClasses>(*classes);
  other->name_by_id[1001] = "cup";
  other->origin = "other/classes.txt";
  frames[1].mask_classes = other;
  const std::string msg = error_of([&] { writer.write(frames[1]); });
  EXPECT_THAT(msg, HasSubstr("frame 1"));
  EXPECT_THAT(msg, HasSubstr("other/classes.txt"));
}

TEST(TumWriter, RejectsBadFramesNamingThem) {
  const fs::path dir = test::fresh_temp_dir();
  auto frames = frames_with_gt_and_masks(3);
  {
    TumFolderWriter writer(dir, small_intrinsics());
    writer.write(frames[0]);
    Frame same_time = frames[1];
    same_time.timestamp_s = frames[0].timestamp_s;
    const std::string msg = error_of([&] { writer.write(same_time); });
    EXPECT_THAT(msg, HasSubstr("frame 1"));
    EXPECT_THAT(msg, HasSubstr("does not increase"));
    Frame no_mask = frames[1];
    no_mask.mask.release();
    EXPECT_THAT(error_of([&] { writer.write(no_mask); }), HasSubstr("has no mask but earlier frames had"));
    Frame big = test::make_test_frame(40, 24, 2, 100.0);
    EXPECT_THAT(error_of([&] { writer.write(big); }), HasSubstr("40x24, expected 32x24"));
  }
  EXPECT_THAT(error_of([&] { TumFolderWriter w(dir, small_intrinsics()); w.finish(); }), HasSubstr("no frames"));
  test::write_text(dir / "file", "x");
  EXPECT_THAT(error_of([&] { TumFolderWriter w(dir / "file" / "sub", small_intrinsics()); }),
              HasSubstr((dir / "file" / "sub").string()));
}

// The real recording converted to klg and read back: same frames, depth within the klg's 1 mm.
TEST(TumWriter, RealFr2ToKlgAndBack) {
  const auto data = test::data_dir("tum_fr2_desk_50");
  if (!data) GTEST_SKIP() << "tum_fr2_desk_50 not found";
  const fs::path dir = test::fresh_temp_dir();
  LimitedSource source(std::make_unique<TumSource>(*data), 5);
  ASSERT_EQ(write_klg(source, dir / "fr2.klg"), 5);
  KlgSourceOptions o;
  o.intrinsics = "fr2";
  KlgSource log(dir / "fr2.klg", o);
  TumSource original(*data);
  for (int i = 0; i < 5; ++i) {
    auto a = original.next();
    auto b = log.next();
    ASSERT_TRUE(a && b);
    EXPECT_NEAR(a->timestamp_s, b->timestamp_s, 1e-6);
    EXPECT_LE(cv::norm(a->depth_m, b->depth_m, cv::NORM_INF), 0.0005 + 1e-6);
    EXPECT_EQ(cv::countNonZero(a->depth_m > 0), cv::countNonZero(b->depth_m > 0));
    EXPECT_LT(cv::norm(a->rgb, b->rgb, cv::NORM_L1) / (640.0 * 480 * 3), 6.0);  // JPEG quality 90
  }
  EXPECT_FALSE(log.next());
}

}  // namespace
}  // namespace cofusion
