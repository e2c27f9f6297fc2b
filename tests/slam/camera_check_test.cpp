// The camera-motion check's depth fit (slam/camera_check.h) on a ray-cast room.
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "common/se3.h"
#include "slam/camera_check.h"

namespace cofusion::slam {
namespace {

// Depth (camera z, metres) of a room seen from T_world_camera: a back wall at z = 3, a floor at
// y = 1, a side wall at x = -1.5 and a box face at z = 2 for x in [0.2, 0.8], y in [-0.2, 0.4].
std::vector<float> room_depth(const Intrinsics& k, const Eigen::Isometry3d& T_world_camera) {
  std::vector<float> depth(size_t(k.width) * size_t(k.height), 0.0f);
  const Eigen::Vector3d o = T_world_camera.translation();
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d ray_c((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);  // z = 1 in the camera
      const Eigen::Vector3d d = T_world_camera.linear() * ray_c;
      double best = std::numeric_limits<double>::infinity();
      const auto hit = [&](int axis, double at, auto&& inside) {
        if (std::abs(d[axis]) < 1e-9) return;
        const double s = (at - o[axis]) / d[axis];
        if (s > 0 && s < best && inside(o + s * d)) best = s;
      };
      hit(2, 3.0, [](const Eigen::Vector3d&) { return true; });
      hit(1, 1.0, [](const Eigen::Vector3d&) { return true; });
      hit(0, -1.5, [](const Eigen::Vector3d&) { return true; });
      hit(2, 2.0, [](const Eigen::Vector3d& p) { return p.x() >= 0.2 && p.x() <= 0.8 && p.y() >= -0.2 && p.y() <= 0.4; });
      if (std::isfinite(best)) depth[size_t(y) * size_t(k.width) + size_t(x)] = float(best);  // s is camera z
    }
  return depth;
}

Eigen::Isometry3d motion(double tx, double ty, double tz, double yaw_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(tx, ty, tz);
  return T;
}

class DepthFit : public ::testing::Test {
 protected:
  Intrinsics k{.fx = 262.5, .fy = 262.5, .cx = 159.5, .cy = 119.5, .width = 320, .height = 240};
  CameraCheckParams params;
  // The reference camera at the origin, the live one moved by T_reference_live.
  const Eigen::Isometry3d T_reference_live = motion(0.02, -0.01, 0.03, 1.5);
  const std::vector<float> reference = room_depth(k, Eigen::Isometry3d::Identity());
  const std::vector<float> live = room_depth(k, T_reference_live);
};

TEST_F(DepthFit, TheTrueMotionFitsAlmostEveryPixel) {
  for (int step : {1, 4, 7}) {
    params.step_px = step;
    EXPECT_GT(depth_fit(live.data(), reference.data(), k, T_reference_live, params), 0.97) << "step " << step;
  }
}

TEST_F(DepthFit, AJumpFitsFarLessThanTheTrueMotion) {
  const double truth = depth_fit(live.data(), reference.data(), k, T_reference_live, params);
  // Jumps like Bonn crowd's: 20-50 cm and 5-10 degrees away from the true motion. (A pure slide
  // along the room's walls and floor, which depth cannot see, is what no depth test refuses.)
  for (const Eigen::Isometry3d& error : {motion(-0.19, -0.07, -0.09, 10), motion(0, 0.2, 0.1, 0), motion(0, 0, 0, 8)}) {
    const double jumped = depth_fit(live.data(), reference.data(), k, T_reference_live * error, params);
    EXPECT_LT(jumped, params.min_fit_ratio * truth);
  }
  // A millimetre-scale error stays within the check's tolerance.
  EXPECT_GT(depth_fit(live.data(), reference.data(), k, T_reference_live * motion(0.003, 0, 0.003, 0.1), params),
            0.95 * truth);
}

TEST_F(DepthFit, PixelsWithoutDepthAreNotCounted) {
  std::vector<float> holes = live;
  for (size_t i = 0; i < holes.size(); i += 2) holes[i] = (i % 4 == 0) ? 0.0f : std::numeric_limits<float>::quiet_NaN();
  params.step_px = 1;
  EXPECT_GT(depth_fit(holes.data(), reference.data(), k, T_reference_live, params), 0.96);
  const std::vector<float> none(live.size(), 0.0f);
  EXPECT_EQ(depth_fit(none.data(), reference.data(), k, T_reference_live, params), 0.0);
  // Without reference depth nothing fits; points moved behind the camera or out of view do not fit.
  EXPECT_EQ(depth_fit(live.data(), none.data(), k, T_reference_live, params), 0.0);
  EXPECT_EQ(depth_fit(live.data(), reference.data(), k, motion(0, 0, -10, 0), params), 0.0);
  EXPECT_EQ(depth_fit(live.data(), reference.data(), k, motion(50, 0, 0, 0), params), 0.0);
}

TEST(ScaledMotion, ScalesAngleAndTranslationAboutTheSameAxis) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.02, -0.01, 0.04);
  EXPECT_TRUE(scaled_motion(T, 1.0).isApprox(T, 1e-12));
  EXPECT_TRUE(scaled_motion(T, 0.0).isApprox(Eigen::Isometry3d::Identity(), 1e-12));
  const Eigen::Isometry3d half = scaled_motion(T, 0.5);
  const Eigen::AngleAxisd r(half.rotation());
  EXPECT_NEAR(r.angle(), 0.15, 1e-12);
  EXPECT_TRUE(r.axis().isApprox(Eigen::Vector3d(1, 2, -1).normalized(), 1e-12));
  EXPECT_TRUE(half.translation().isApprox(Eigen::Vector3d(0.01, -0.005, 0.02), 1e-12));
  // Halving twice is a quarter; no motion stays none.
  EXPECT_TRUE(scaled_motion(half, 0.5).isApprox(scaled_motion(T, 0.25), 1e-12));
  EXPECT_TRUE(scaled_motion(Eigen::Isometry3d::Identity(), 0.5).isApprox(Eigen::Isometry3d::Identity(), 1e-12));
}

// CameraCheckParams::keyframe_pose_gain: the replacement moved part of the way to the keyframes'
// pose, on the motions' difference (not on their translations alone).
TEST(MotionTowards, MovesTheGivenFractionOfTheDifference) {
  Eigen::Isometry3d from = Eigen::Isometry3d::Identity(), to = Eigen::Isometry3d::Identity();
  from.translation() = Eigen::Vector3d(0.01, 0.0, 0.0);
  to.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  to.translation() = Eigen::Vector3d(0.05, -0.02, 0.1);
  EXPECT_TRUE(motion_towards(from, to, 0.0).isApprox(from, 1e-12));
  EXPECT_TRUE(motion_towards(from, to, 1.0).isApprox(to, 1e-12));
  const Eigen::Isometry3d half = motion_towards(from, to, 0.5);
  EXPECT_NEAR(Eigen::AngleAxisd(half.rotation()).angle(), 0.1, 1e-12);
  // `from` has no rotation, so the translation goes halfway too.
  EXPECT_TRUE(half.translation().isApprox(from.translation() + 0.5 * (to.translation() - from.translation()), 1e-12));
  // Halfway again from there: three quarters of the rotation (the same axis).
  EXPECT_NEAR(Eigen::AngleAxisd(motion_towards(half, to, 0.5).rotation()).angle(), 0.15, 1e-12);
}

// The camera check's rules (CameraCheckParams: min_fit_ratio 0.8, replaced_motion_scale 0.5).
TEST(DecideCameraMotion, StandsReplacesOrLoses) {
  const CameraCheckParams p;
  CameraFits f;
  f.guess.translation() = Eigen::Vector3d(0.02, 0.0, 0.0);
  f.from_guess = true;
  f.start = 0.9;
  const auto verdict = [&](bool failed, bool agree, double last_fit) {
    return decide_camera_motion(f, failed, agree, last_fit, p).verdict;
  };
  // Tracked, fitting at least 0.8 of the better start: it stands.
  f.tracked = 0.75;  // 0.83 of the start
  EXPECT_EQ(verdict(false, false, 0.9), CameraVerdict::kStands);
  // Refused (0.5 of the start): the guess at half speed replaces it...
  f.tracked = 0.45;
  CameraDecision d = decide_camera_motion(f, false, false, 0.9, p);
  EXPECT_EQ(d.verdict, CameraVerdict::kReplaced);
  EXPECT_TRUE(d.motion.translation().isApprox(Eigen::Vector3d(0.01, 0.0, 0.0), 1e-12));
  // ... or no motion where that fits better ...
  f.from_guess = false;
  d = decide_camera_motion(f, false, false, 0.9, p);
  EXPECT_EQ(d.verdict, CameraVerdict::kReplaced);
  EXPECT_TRUE(d.motion.isApprox(Eigen::Isometry3d::Identity(), 1e-12));
  // ... unless the refused poses have agreed for agreeing_frames: then the tracked motion stands.
  EXPECT_EQ(verdict(false, true, 0.9), CameraVerdict::kStands);
  // A failed tracking: replaced where the start fits at least 0.8 of the last frame's fit (0.9 of
  // 0.95 here), else lost (a covered lens: nothing fits); agreement does not save a failed one.
  EXPECT_EQ(verdict(true, false, 0.95), CameraVerdict::kReplaced);
  EXPECT_EQ(verdict(true, true, 0.95), CameraVerdict::kReplaced);
  f.start = 0.1;
  EXPECT_EQ(verdict(true, false, 0.95), CameraVerdict::kLost);
  // The first frames have no last fit (0): a failed tracking is replaced.
  EXPECT_EQ(verdict(true, false, 0.0), CameraVerdict::kReplaced);
}

}  // namespace
}  // namespace cofusion::slam
