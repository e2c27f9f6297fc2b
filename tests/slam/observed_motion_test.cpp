// The probation's observed-motion test (slam/observed_motion.h) on a rendered scene: a textured
// box's face in front of a textured wall, seen by a camera at the world's origin. A box that moved
// is explained by its motion and not where it was; a wall patch "moving" along the wall (the drift
// of a static surface tracked by its plane alone) is explained at least as well where it was; a
// texture-less bar that slides along its length shows its motion only backwards.
#include <cmath>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "slam/observed_motion.h"

namespace cofusion::slam {
namespace {

constexpr float kWallZ = 3.0f, kBoxZ = 1.5f, kBoxHalf = 0.15f;

struct Frame {
  std::vector<float> depth;
  std::vector<uint8_t> rgb;
};

// Stripes of 4 cm along x, in grey levels 60 and 180 (times `gain`).
uint8_t stripes(double x_m, double gain) {
  const bool light = int(std::floor(x_m / 0.04)) % 2 == 0;
  return static_cast<uint8_t>(std::lround(std::min(255.0, gain * (light ? 180.0 : 60.0))));
}

// The box's square face (centre `box_x` m along x) in front of the wall; both striped along x in
// their own frames; the camera `camera_x` m along x from the world's origin, looking along z.
Frame render(const Intrinsics& k, double box_x, double gain = 1.0, double camera_x = 0.0) {
  Frame f{std::vector<float>(size_t(k.width) * size_t(k.height)), std::vector<uint8_t>(3 * size_t(k.width) * size_t(k.height))};
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const size_t i = size_t(y) * size_t(k.width) + size_t(x);
      const double rx = (x - k.cx) / k.fx, ry = (y - k.cy) / k.fy;
      const double bx = rx * kBoxZ + camera_x - box_x, by = ry * kBoxZ;
      const bool box = std::abs(bx) <= kBoxHalf && std::abs(by) <= kBoxHalf;
      f.depth[i] = box ? kBoxZ : kWallZ;
      const uint8_t g = box ? stripes(bx + 1.0, gain) : stripes(rx * kWallZ + camera_x + 10.0, gain);
      for (int c = 0; c < 3; ++c) f.rgb[3 * i + size_t(c)] = g;
    }
  return f;
}

// The pixels whose camera ray meets the box's face (centre box_x) or, for `wall`, a wall patch
// of the same size around x = 0.6 m.
std::vector<size_t> region(const Intrinsics& k, double box_x, bool wall) {
  std::vector<size_t> pixels;
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const double rx = (x - k.cx) / k.fx, ry = (y - k.cy) / k.fy;
      const bool in = wall ? std::abs(rx * kWallZ - 0.6) <= 0.3 && std::abs(ry * kWallZ) <= 0.3
                           : std::abs(rx * kBoxZ - box_x) <= kBoxHalf && std::abs(ry * kBoxZ) <= kBoxHalf;
      if (in) pixels.push_back(size_t(y) * size_t(k.width) + size_t(x));
    }
  return pixels;
}

Eigen::Isometry3d shift(double x_m, double z_m = 0.0) {
  return Eigen::Isometry3d(Eigen::Translation3d(x_m, 0.0, z_m));
}

class ObservedMotion : public ::testing::Test {
 protected:
  Intrinsics k_;  // 640x480, f = 525
  ObservedMotionParams p_;
  const Eigen::Isometry3d camera_ = Eigen::Isometry3d::Identity();
};

TEST_F(ObservedMotion, AMovedBoxIsExplainedByItsMotionAlone) {
  const Frame before = render(k_, -0.3), after = render(k_, -0.25);  // 5 cm to the right
  const auto points = sample_region_points(region(k_, -0.3, false), before.depth.data(), before.rgb.data(), k_,
                                           camera_, p_.points);
  ASSERT_EQ(points.size(), size_t(p_.points));
  const ObservedShares s = observed_shares(points, shift(0.05), after.depth.data(), after.rgb.data(), k_, camera_, p_);
  EXPECT_GT(s.moved, 0.9);  // all but points on a stripe's edge, where the pixel grid rounds
  EXPECT_LT(s.still, 0.8);
  EXPECT_TRUE(motion_shows(s, p_));
}

TEST_F(ObservedMotion, AnExposureChangeDoesNotHideTheMotion) {
  const Frame before = render(k_, -0.3), after = render(k_, -0.25, 1.3);
  const auto points = sample_region_points(region(k_, -0.3, false), before.depth.data(), before.rgb.data(), k_,
                                           camera_, p_.points);
  const ObservedShares s = observed_shares(points, shift(0.05), after.depth.data(), after.rgb.data(), k_, camera_, p_);
  EXPECT_GT(s.moved, 0.9);  // all but points on a stripe's edge, where the pixel grid rounds
  EXPECT_TRUE(motion_shows(s, p_));
}

TEST_F(ObservedMotion, AWallPatchSlidingAlongTheWallShowsNoMotion) {
  const Frame f = render(k_, -0.3);  // nothing moved
  const auto points = sample_region_points(region(k_, -0.3, true), f.depth.data(), f.rgb.data(), k_, camera_, p_.points);
  ASSERT_FALSE(points.empty());
  for (const double slide_m : {0.03, 0.05, 0.1}) {
    const ObservedShares s = observed_shares(points, shift(slide_m), f.depth.data(), f.rgb.data(), k_, camera_, p_);
    EXPECT_GT(s.still, 0.95) << slide_m;
    EXPECT_FALSE(motion_shows(s, p_)) << slide_m;
  }
  // Moved off the wall towards the camera by 10 cm, far beyond the depth noise at 3 m: that shows.
  const ObservedShares off = observed_shares(points, shift(0.0, -0.1), f.depth.data(), f.rgb.data(), k_, camera_, p_);
  EXPECT_LT(off.moved, 0.05);
}

// The camera moves 0.32 m to the right and a wall patch at the image's left border "follows" it
// (8 stripes on, the same grey): where it was, 44 of its 106 columns are out of view now. Only
// the points in view for both count, and those show no motion.
TEST_F(ObservedMotion, PointsOutOfViewWhereTheyWereDoNotCount) {
  const Frame before = render(k_, 10.0);
  std::vector<size_t> border;
  for (size_t i : region(k_, 0.0, true)) border.push_back(i - 360);  // the patch moved to u = 12..117
  const auto points = sample_region_points(border, before.depth.data(), before.rgb.data(), k_, camera_, p_.points);
  const Frame after = render(k_, 10.0, 1.0, 0.32);
  const ObservedShares s =
      observed_shares(points, shift(0.32), after.depth.data(), after.rgb.data(), k_, shift(0.32), p_);
  EXPECT_NEAR(s.counted, 62.0 / 106.0, 0.03);
  EXPECT_GT(s.counted, p_.min_counted);
  EXPECT_GT(s.still, 0.9);
  EXPECT_FALSE(motion_shows(s, p_));
}

// A texture-less bar that reaches in from the image's left border, its end `end_x` m along x,
// in front of the striped wall.
Frame render_bar(const Intrinsics& k, double end_x) {
  Frame f = render(k, 10.0);  // the box far out of view
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const double rx = (x - k.cx) / k.fx, ry = (y - k.cy) / k.fy;
      if (rx * kBoxZ > end_x || std::abs(ry * kBoxZ) > 0.05) continue;
      const size_t i = size_t(y) * size_t(k.width) + size_t(x);
      f.depth[i] = kBoxZ;
      for (int c = 0; c < 3; ++c) f.rgb[3 * i + size_t(c)] = 120;
    }
  return f;
}

std::vector<size_t> bar_pixels(const Frame& f) {
  std::vector<size_t> pixels;
  for (size_t i = 0; i < f.depth.size(); ++i)
    if (f.depth[i] == kBoxZ) pixels.push_back(i);
  return pixels;
}

// Sliding 25 cm along its length, the bar shows the same at its old points (forwards nothing
// tells); backwards, its pixels beyond where it ended then showed the wall.
TEST_F(ObservedMotion, ABarSlidingAlongItsLengthShowsItsMotionBackwards) {
  const Frame before = render_bar(k_, -0.5), after = render_bar(k_, -0.25);
  const SpawnEvidence spawn = record_spawn(bar_pixels(before), before.depth.data(), before.rgb.data(), k_, camera_, p_);
  ASSERT_EQ(spawn.points.size(), size_t(p_.points));
  const ObservedShares forwards =
      observed_shares(spawn.points, shift(0.25), after.depth.data(), after.rgb.data(), k_, camera_, p_);
  EXPECT_GT(forwards.still, 0.95);
  EXPECT_FALSE(motion_shows(forwards, p_));
  EXPECT_TRUE(motion_observed(spawn, bar_pixels(after), shift(0.25), after.depth.data(), after.rgb.data(), k_,
                              camera_, p_));
  // Had it stayed (its model drifting along it), neither direction would show a motion.
  EXPECT_FALSE(motion_observed(spawn, bar_pixels(before), shift(0.25), before.depth.data(), before.rgb.data(), k_,
                               camera_, p_));
}

TEST_F(ObservedMotion, AWallPatchSlidingAlongTheWallShowsNoMotionEitherWay) {
  const Frame f = render(k_, -0.3);
  const std::vector<size_t> patch = region(k_, -0.3, true);
  const SpawnEvidence spawn = record_spawn(patch, f.depth.data(), f.rgb.data(), k_, camera_, p_);
  for (const double slide_m : {0.03, 0.1})
    EXPECT_FALSE(motion_observed(spawn, patch, shift(slide_m), f.depth.data(), f.rgb.data(), k_, camera_, p_))
        << slide_m;
  // A box that moved shows it.
  const Frame before = render(k_, -0.3), after = render(k_, -0.25);
  const SpawnEvidence box =
      record_spawn(region(k_, -0.3, false), before.depth.data(), before.rgb.data(), k_, camera_, p_);
  EXPECT_TRUE(motion_observed(box, region(k_, -0.25, false), shift(0.05), after.depth.data(), after.rgb.data(), k_,
                              camera_, p_));
}

TEST_F(ObservedMotion, NoPointsNoShares) {
  const Frame f = render(k_, -0.3);
  EXPECT_TRUE(sample_region_points({}, f.depth.data(), f.rgb.data(), k_, camera_, p_.points).empty());
  const ObservedShares s = observed_shares({}, shift(0.05), f.depth.data(), f.rgb.data(), k_, camera_, p_);
  EXPECT_EQ(s.moved, 0.0);
  EXPECT_EQ(s.still, 0.0);
  // A spawn without points (or with the test off) decides nothing: the motion counts as shown.
  p_.points = 0;
  const SpawnEvidence off = record_spawn(region(k_, -0.3, false), f.depth.data(), f.rgb.data(), k_, camera_, p_);
  EXPECT_TRUE(off.points.empty());
  EXPECT_TRUE(off.depth_m.empty());
  EXPECT_TRUE(motion_observed(off, {}, shift(0.05), f.depth.data(), f.rgb.data(), k_, camera_, p_));
}

TEST_F(ObservedMotion, PointsWithoutDepthAreNotSampled) {
  Frame f = render(k_, -0.3);
  const std::vector<size_t> pixels = region(k_, -0.3, false);
  for (size_t j = 0; j < pixels.size(); j += 2) f.depth[pixels[j]] = 0.0f;
  const auto points = sample_region_points(pixels, f.depth.data(), f.rgb.data(), k_, camera_, int(pixels.size()));
  EXPECT_EQ(points.size(), pixels.size() / 2);
  for (const ObservedPoint& pt : points) EXPECT_NEAR(pt.p_world.z(), kBoxZ, 1e-5);
}

}  // namespace
}  // namespace cofusion::slam
