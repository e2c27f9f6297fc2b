// The spawn-time rigidity check (slam/region_rigidity.h) on ray-cast balls in front of a wall: a
// ball that moved rigidly aligns almost wholly, a body whose part swung away does not, a ball
// entering the view is judged by the part that was in view, an empty region by nothing.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "slam/region_rigidity.h"

namespace cofusion::slam {
namespace {

struct Ball {
  Eigen::Vector3d centre;  // camera frame, metres
  double radius_m;
};

// Depth of balls in front of a wall at z = 3 m; `owner` gets each pixel's ball index (or -1).
std::vector<float> render(const Intrinsics& k, const std::vector<Ball>& balls, std::vector<int>* owner = nullptr) {
  std::vector<float> depth(size_t(k.width) * size_t(k.height), 3.0f);
  if (owner) owner->assign(depth.size(), -1);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d r((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);  // s * r has camera z = s
      const size_t i = size_t(y) * size_t(k.width) + size_t(x);
      for (size_t b = 0; b < balls.size(); ++b) {
        const Eigen::Vector3d& c = balls[b].centre;
        const double rc = r.dot(c), disc = rc * rc - r.squaredNorm() * (c.squaredNorm() - balls[b].radius_m * balls[b].radius_m);
        if (disc < 0) continue;
        const double s = (rc - std::sqrt(disc)) / r.squaredNorm();
        if (s > 0 && s < depth[i]) {
          depth[i] = float(s);
          if (owner) (*owner)[i] = int(b);
        }
      }
    }
  return depth;
}

std::vector<size_t> pixels_of(const std::vector<int>& owner) {
  std::vector<size_t> out;
  for (size_t i = 0; i < owner.size(); ++i)
    if (owner[i] >= 0) out.push_back(i);
  return out;
}

class RegionRigidityTest : public ::testing::Test {
 protected:
  Intrinsics k{.fx = 262.5, .fy = 262.5, .cx = 159.5, .cy = 119.5, .width = 320, .height = 240};
  RegionRigidityParams params;
};

TEST_F(RegionRigidityTest, ABallThatMovedRigidlyAlignsAndItsMotionIsFound) {
  const Eigen::Vector3d before_centre(0.1, 0.0, 2.0), t(0.03, -0.02, 0.02);  // 4 cm, unknown to the guess
  const std::vector<float> before = render(k, {{before_centre, 0.25}});
  std::vector<int> owner;
  const std::vector<float> now = render(k, {{before_centre + t, 0.25}}, &owner);
  const RegionRigidity r = region_rigidity(now.data(), before.data(), k, pixels_of(owner), Eigen::Isometry3d::Identity(), params);
  EXPECT_GT(r.points, 1000);
  EXPECT_EQ(r.in_view, r.points);
  EXPECT_GT(r.aligned_fraction(), 0.9) << "all but the rim, whose pixels straddle the wall";
  // A ball's alignment is where its centre goes (its turns about the centre are invisible).
  EXPECT_LT((r.T_previous_current * (before_centre + t) - before_centre).norm(), 0.005);
  EXPECT_GE(r.aligned_fraction(), params.min_aligned_fraction) << "it would spawn";
}

TEST_F(RegionRigidityTest, ABodyWhosePartSwungAwayDoesNotAlign) {
  // A torso that moved 2 cm and a part beside it that swung 40 cm away from it: one region (the
  // two touch in the image), two motions.
  const std::vector<Ball> before = {{{0.0, 0.0, 2.0}, 0.25}, {{0.4, 0.0, 1.9}, 0.18}};
  const std::vector<Ball> after = {{{0.02, 0.0, 2.0}, 0.25}, {{-0.4, 0.0, 1.9}, 0.18}};
  std::vector<int> owner;
  const std::vector<float> now = render(k, after, &owner);
  const std::vector<float> then = render(k, before);
  const RegionRigidity r = region_rigidity(now.data(), then.data(), k, pixels_of(owner), Eigen::Isometry3d::Identity(), params);
  EXPECT_GT(r.points, 1000);
  EXPECT_LT(r.aligned_fraction(), params.min_aligned_fraction) << "it spawns nothing";
  EXPECT_GT(r.aligned_fraction(), 0.4) << "the torso still aligns";
}

TEST_F(RegionRigidityTest, PointsThatWereOutOfViewDoNotCount) {
  // A ball entering from the left: a third of it was outside the previous image.
  const std::vector<float> before = render(k, {{{-1.6, 0.0, 2.5}, 0.35}});
  std::vector<int> owner;
  const std::vector<float> now = render(k, {{{-1.45, 0.0, 2.5}, 0.35}}, &owner);
  const Eigen::Isometry3d guess(Eigen::Translation3d(-0.15, 0.0, 0.0));  // the region's centroid step
  const RegionRigidity r = region_rigidity(now.data(), before.data(), k, pixels_of(owner), guess, params);
  EXPECT_LT(r.in_view, r.points * 0.9);
  EXPECT_GT(r.in_view, 100);
  EXPECT_GT(r.aligned_fraction(), 0.85);
}

TEST_F(RegionRigidityTest, NoPixelsNoAlignment) {
  const std::vector<float> wall = render(k, {});
  const RegionRigidity r = region_rigidity(wall.data(), wall.data(), k, {}, Eigen::Isometry3d::Identity(), params);
  EXPECT_EQ(r.points, 0);
  EXPECT_EQ(r.aligned_fraction(), 0.0);
}

}  // namespace
}  // namespace cofusion::slam
