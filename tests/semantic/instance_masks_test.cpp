// Boxes + depth -> instance masks on synthetic depth: a box standing on a tilted plane (the mask
// covers the box, not the plane it stands on nor the plane behind it), a duplicate detection, a
// person from the segmenter's probability, a wall the object touches (the concave cut), an
// object with a concave fold of its own, bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include <opencv2/imgproc.hpp>

#include "semantic/instance_masks.h"
#include "support/test_support.h"

namespace cofusion::semantic {
namespace {

Intrinsics small_camera() {
  Intrinsics k;
  k.fx = k.fy = 150.0;
  k.cx = 79.5;
  k.cy = 59.5;
  k.width = 160;
  k.height = 120;
  return k;
}

// A camera looking down at a floor (n . p = c: about 2 m ahead at the image centre, farther
// towards the top), with an upright box face (constant depth) standing on it: rows [top, bottom]
// and columns [left, right] of the image. Optional Gaussian noise of sigma_rel x depth.
struct Scene {
  cv::Mat depth_m;
  cv::Rect object;  // the object's pixels
};

float floor_depth(int y, const Intrinsics& k) {
  const double ry = (y - k.cy) / k.fy;
  const double nd = 0.8 * ry + 0.6;  // n = (0, 0.8, 0.6), c = 1.2
  return static_cast<float>(1.2 / nd);
}

Scene box_on_floor(const Intrinsics& k, double sigma_rel = 0.0) {
  Scene s;
  s.depth_m = cv::Mat(k.height, k.width, CV_32FC1);
  s.object = cv::Rect(60, 40, 40, 36);  // rows 40..75, standing on the floor at row 75
  const float face = floor_depth(s.object.y + s.object.height - 1, k);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      float d = s.object.contains({x, y}) ? face : floor_depth(y, k);
      if (sigma_rel > 0) d *= static_cast<float>(1.0 + sigma_rel * noise(rng));
      s.depth_m.at<float>(y, x) = d;
    }
  return s;
}

Detection detection(int class_id, const std::string& name, float score, cv::Rect2f box) {
  Detection d;
  d.class_id = class_id;
  d.class_name = name;
  d.score = score;
  d.box_px = box;
  return d;
}

// Share of `region`'s pixels (within `area`) whose id is `id`.
double share_with_id(const cv::Mat& ids, const cv::Rect& area, const std::function<bool(int, int)>& region, uint16_t id) {
  int n = 0, hit = 0;
  for (int y = area.y; y < area.y + area.height; ++y)
    for (int x = area.x; x < area.x + area.width; ++x)
      if (region(x, y)) {
        ++n;
        hit += ids.at<uint16_t>(y, x) == id;
      }
  return n == 0 ? 0.0 : static_cast<double>(hit) / n;
}

void expect_box_not_floor(const Scene& s, const InstanceMasks& m, const cv::Rect& box, double min_cover) {
  ASSERT_EQ(m.instances.size(), 1u);
  const Instance& inst = m.instances[0];
  EXPECT_EQ(inst.id, 1);
  EXPECT_EQ(inst.class_name, "suitcase");
  const cv::Mat& ids = m.ids;
  EXPECT_EQ(ids.type(), CV_16UC1);
  const double cover = share_with_id(ids, box, [&](int x, int y) { return s.object.contains({x, y}); }, 1);
  const double floor = share_with_id(ids, box, [&](int x, int y) { return !s.object.contains({x, y}); }, 1);
  EXPECT_GE(cover, min_cover) << "the mask covers the box";
  EXPECT_LE(floor, 0.01) << "and not the floor in its box (in front of it and behind it)";
  EXPECT_EQ(cv::countNonZero(ids(cv::Rect(0, 0, ids.cols, ids.rows)) != 0), inst.pixels);
  const cv::Rect outside_rows(0, 0, ids.cols, box.y);
  EXPECT_EQ(cv::countNonZero(ids(outside_rows)), 0) << "nothing outside the detection's box";
}

TEST(InstanceMasks, ABoxOnAFloorIsCutFromTheFloor) {
  const Intrinsics k = small_camera();
  const Scene s = box_on_floor(k);
  const cv::Rect box(54, 34, 52, 50);  // the detection: a bit larger than the object, floor around
  const auto m = instance_masks({detection(28, "suitcase", 0.8f, box)}, s.depth_m, k, {});
  expect_box_not_floor(s, m, box, 0.9);
}

TEST(InstanceMasks, ABoxOnAFloorWithKinectLikeNoise) {
  const Intrinsics k = small_camera();
  const Scene s = box_on_floor(k, 0.002);  // 0.2 % of depth: about 4 mm at 2 m
  const cv::Rect box(54, 34, 52, 50);
  const auto m = instance_masks({detection(28, "suitcase", 0.8f, box)}, s.depth_m, k, {});
  expect_box_not_floor(s, m, box, 0.85);
}

TEST(InstanceMasks, HolesAtTheCentreAndMissingDepthAreSkipped) {
  const Intrinsics k = small_camera();
  Scene s = box_on_floor(k);
  s.depth_m(cv::Rect(74, 52, 12, 12)).setTo(0.f);  // no reading at the box's centre
  s.depth_m.at<float>(45, 65) = std::nanf("");
  const cv::Rect box(54, 34, 52, 50);
  const auto m = instance_masks({detection(28, "suitcase", 0.8f, box)}, s.depth_m, k, {});
  expect_box_not_floor(s, m, box, 0.8);
  EXPECT_EQ(m.ids.at<uint16_t>(58, 80), 0) << "pixels without depth are no instance";
}

TEST(InstanceMasks, ADuplicateDetectionOfTheSameObjectIsDropped) {
  const Intrinsics k = small_camera();
  const Scene s = box_on_floor(k);
  const cv::Rect box(54, 34, 52, 50);
  const auto m = instance_masks({detection(67, "cell_phone", 0.3f, box), detection(28, "suitcase", 0.8f, box)},
                                s.depth_m, k, {});
  expect_box_not_floor(s, m, box, 0.9);  // the better one wins, the other has no pixels left
}

// A box face (constant depth) standing on the floor and touching a wall on its right: the wall
// (a vertical plane turned 56 degrees from the face, z = face - 1.5 (X - X_contact), nearer towards
// the image's right) meets the face at its right edge without a depth step. The floor is the
// support plane; only the concave fold where face and wall meet separates the wall's pixels in
// the box from the object.
Scene box_in_a_corner(const Intrinsics& k, cv::Rect& wall_in_box) {
  Scene s = box_on_floor(k);
  const double face = s.depth_m.at<float>(s.object.y, s.object.x), slope = 1.5;
  const int contact = s.object.x + s.object.width;  // first wall column
  const double x_contact = face * (contact - k.cx) / k.fx;
  for (int y = 0; y < k.height; ++y)
    for (int x = contact; x < k.width; ++x) {
      const float wall = static_cast<float>((face + slope * x_contact) / (1.0 + slope * (x - k.cx) / k.fx));
      s.depth_m.at<float>(y, x) = std::min(wall, floor_depth(y, k));
    }
  wall_in_box = cv::Rect(contact, s.object.y, 6, s.object.height);
  return s;
}

TEST(InstanceMasks, AWallTheObjectTouchesIsCutAtTheConcaveFold) {
  const Intrinsics k = small_camera();
  cv::Rect wall;
  const Scene s = box_in_a_corner(k, wall);
  const cv::Rect box(54, 34, 52, 50);  // 6 columns of wall inside on the right
  const auto on_wall = [&](int x, int y) { return wall.contains({x, y}); };
  const auto on_object = [&](int x, int y) { return s.object.contains({x, y}); };
  const auto m = instance_masks({detection(28, "suitcase", 0.8f, box)}, s.depth_m, k, {});
  ASSERT_EQ(m.instances.size(), 1u);
  EXPECT_GE(share_with_id(m.ids, box, on_object, 1), 0.9);
  EXPECT_LE(share_with_id(m.ids, box, on_wall, 1), 0.2) << "at most the fold's own pixels of the wall";
  InstanceMaskParams no_cut;
  no_cut.fold_angle_deg = 0;
  const auto uncut = instance_masks({detection(28, "suitcase", 0.8f, box)}, s.depth_m, k, no_cut);
  ASSERT_EQ(uncut.instances.size(), 1u);
  EXPECT_GE(share_with_id(uncut.ids, box, on_wall, 1), 0.9) << "without the cut the wall joins the object";
}

TEST(InstanceMasks, AnObjectsOwnConcaveFoldInsideTheBoxKeepsItWhole) {
  // A chair: an upright backrest (constant depth 1.4 m) and a horizontal seat in front of it at
  // its foot (y = 0.3 m below the camera, 0.4 m deep), with the floor far behind; the seat meets
  // the backrest at a concave fold, both inside the box.
  const Intrinsics k = small_camera();
  cv::Mat depth(k.height, k.width, CV_32FC1, cv::Scalar(4.f));
  const float back = 1.4f, seat_y = 0.3f;
  const int seat_top = static_cast<int>(std::ceil(k.cy + k.fy * seat_y / back));           // row 92
  const int seat_bottom = static_cast<int>(std::floor(k.cy + k.fy * seat_y / (back - 0.4f)));  // row 104
  const cv::Rect backrest(55, 30, 50, seat_top - 30), seat(55, seat_top, 50, seat_bottom - seat_top + 1);
  depth(backrest).setTo(back);
  for (int y = seat.y; y < seat.y + seat.height; ++y)
    depth(cv::Rect(seat.x, y, seat.width, 1)).setTo(static_cast<float>(seat_y / ((y - k.cy) / k.fy)));
  const cv::Rect box(50, 25, 60, 85);
  const auto m = instance_masks({detection(56, "chair", 0.8f, box)}, depth, k, {});
  ASSERT_EQ(m.instances.size(), 1u);
  EXPECT_GE(share_with_id(m.ids, box, [&](int x, int y) { return backrest.contains({x, y}); }, 1), 0.9);
  EXPECT_GE(share_with_id(m.ids, box, [&](int x, int y) { return seat.contains({x, y}); }, 1), 0.9);
}

TEST(InstanceMasks, PeopleComeFromThePersonProbability) {
  const Intrinsics k = small_camera();
  const Scene s = box_on_floor(k);
  cv::Mat person(s.depth_m.size(), CV_32FC1, cv::Scalar(0.f));
  cv::circle(person, {30, 60}, 15, cv::Scalar(0.9f), -1);
  const cv::Rect box(10, 40, 40, 40);
  const auto m = instance_masks({detection(0, "person", 0.7f, box)}, s.depth_m, k, {}, person);
  ASSERT_EQ(m.instances.size(), 1u);
  EXPECT_EQ(m.instances[0].class_id, 0);
  EXPECT_EQ(m.ids.at<uint16_t>(60, 30), 1);
  EXPECT_EQ(m.ids.at<uint16_t>(42, 12), 0) << "box corner, outside the person";
  EXPECT_NEAR(m.instances[0].pixels, CV_PI * 15 * 15, 60);
}

TEST(InstanceMasks, ThePersonSegmentersPixelsGrowOverDepthToTheLegs) {
  // The segmenter marks only the upper part of an upright body (as the selfie model does); the
  // rest joins it over continuous depth, the floor it stands on and the floor behind stay out.
  const Intrinsics k = small_camera();
  const Scene s = box_on_floor(k);
  cv::Mat person(s.depth_m.size(), CV_32FC1, cv::Scalar(0.f));
  person(cv::Rect(62, 40, 36, 14)).setTo(0.9f);
  const cv::Rect box(54, 34, 52, 50);
  const auto grown = instance_masks({detection(0, "person", 0.7f, box)}, s.depth_m, k, {}, person);
  ASSERT_EQ(grown.instances.size(), 1u);
  const auto on_object = [&](int x, int y) { return s.object.contains({x, y}); };
  const auto off_object = [&](int x, int y) { return !s.object.contains({x, y}); };
  EXPECT_GE(share_with_id(grown.ids, box, on_object, 1), 0.9);
  EXPECT_LE(share_with_id(grown.ids, box, off_object, 1), 0.01);
  InstanceMaskParams p;
  p.grow_people_over_depth = false;
  const auto plain = instance_masks({detection(0, "person", 0.7f, box)}, s.depth_m, k, p, person);
  ASSERT_EQ(plain.instances.size(), 1u);
  EXPECT_EQ(plain.instances[0].pixels, 36 * 14) << "without growing: the segmenter's pixels";
}


TEST(InstanceMasks, AnotherClassOnThePersonSegmentersPixelsIsAPerson) {
  // The detector calls the upright body an elephant; the segmenter marks 70% of it (or 30%).
  const Intrinsics k = small_camera();
  const Scene s = box_on_floor(k);
  const cv::Rect box(54, 34, 52, 50);
  for (const int marked_rows : {25, 11}) {
    cv::Mat person(s.depth_m.size(), CV_32FC1, cv::Scalar(0.f));
    person(cv::Rect(s.object.x, s.object.y, s.object.width, marked_rows)).setTo(0.9f);
    const auto m = instance_masks({detection(20, "elephant", 0.5f, box)}, s.depth_m, k, {}, person);
    ASSERT_EQ(m.instances.size(), 1u);
    const bool person_expected = marked_rows == 25;
    EXPECT_EQ(m.instances[0].class_name, person_expected ? "person" : "elephant") << marked_rows << " rows marked";
    EXPECT_EQ(m.instances[0].class_id, person_expected ? 0 : 20);
    EXPECT_GE(share_with_id(m.ids, box, [&](int x, int y) { return s.object.contains({x, y}); }, 1), 0.9)
        << "the mask is the depth-grown one either way";
  }
}
TEST(InstanceMasks, RejectsBadInput) {
  const Intrinsics k = small_camera();
  EXPECT_NE(test::error_of([&] { (void)instance_masks({}, cv::Mat(), k, {}); }), "(no error)");
  EXPECT_NE(test::error_of([&] { (void)instance_masks({}, cv::Mat(10, 10, CV_16UC1), k, {}); }), "(no error)");
  EXPECT_NE(test::error_of([&] {
              (void)instance_masks({}, cv::Mat(10, 10, CV_32FC1, 1.f), k, {}, cv::Mat(5, 5, CV_32FC1));
            }),
            "(no error)");
  const auto none = instance_masks({}, cv::Mat(10, 10, CV_32FC1, 1.f), k, {});
  EXPECT_TRUE(none.instances.empty());
  EXPECT_EQ(cv::countNonZero(none.ids), 0);
}

}  // namespace
}  // namespace cofusion::semantic
