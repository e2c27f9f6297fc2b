// unwarp_colour: a colour image taken row by row while the camera turns is resampled to the view
// of its middle row. Checked against images made here with a rolling shutter from a known turn.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "slam/rolling_shutter.h"

namespace cofusion::test {
namespace {

constexpr int kWidth = 160, kHeight = 120;
constexpr double kInterval = 1.0 / 30.0;

Intrinsics small_camera() {
  Intrinsics k;
  k.fx = 130.0, k.fy = 129.0, k.cx = 79.2, k.cy = 61.3;
  k.width = kWidth, k.height = kHeight;
  return k;
}

// A smooth pattern over the view's directions (so that it can be sampled anywhere): the colour a
// global shutter sees along ray (x, y, 1).
void pattern(double x, double y, uint8_t* px) {
  px[0] = uint8_t(128 + 100 * std::sin(9 * x) * std::cos(7 * y));
  px[1] = uint8_t(128 + 100 * std::cos(11 * x + 5 * y));
  px[2] = uint8_t(128 + 100 * std::sin(6 * y - 4 * x));
}

// The image a camera turning at `w_rad_s` (body frame) takes with rows read over `readout_s`, its
// middle row's view being `pattern`: row v sees the pattern turned by the rotation since then.
std::vector<uint8_t> rolling_shutter_image(const Intrinsics& k, const Eigen::Vector3d& w_rad_s, double readout_s) {
  std::vector<uint8_t> img(size_t(kWidth) * kHeight * 3);
  for (int v = 0; v < kHeight; ++v) {
    const double t = ((v + 0.5) / kHeight - 0.5) * readout_s;
    const Eigen::Vector3d turn = w_rad_s * t;
    const Eigen::Matrix3d R_middle_row =
        turn.norm() > 0 ? Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
    for (int u = 0; u < kWidth; ++u) {
      const Eigen::Vector3d r = R_middle_row * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      pattern(r.x() / r.z(), r.y() / r.z(), &img[(size_t(v) * kWidth + u) * 3]);
    }
  }
  return img;
}

Eigen::Isometry3d motion_over(const Eigen::Vector3d& w_rad_s, double interval_s) {
  const Eigen::Vector3d turn = w_rad_s * interval_s;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.01, -0.02, 0.005);  // ignored: rotation only
  return T;
}

// Mean absolute difference per channel over the pixels at least `margin` from the border.
double mean_difference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int margin) {
  double sum = 0;
  int n = 0;
  for (int v = margin; v < kHeight - margin; ++v)
    for (int u = margin; u < kWidth - margin; ++u)
      for (int c = 0; c < 3; ++c, ++n) {
        const size_t i = (size_t(v) * kWidth + u) * 3 + c;
        sum += std::abs(int(a[i]) - int(b[i]));
      }
  return sum / n;
}

TEST(RollingShutter, AFastTurnIsUndoneToTheMiddleRowsView) {
  const Intrinsics k = small_camera();
  const std::vector<uint8_t> global = rolling_shutter_image(k, Eigen::Vector3d::Zero(), 0.0);
  // A turn of about 170 degrees per second about all three axes, rows read top-down and bottom-up:
  // the first and last rows turn by 2.5 degrees (up to 6 pixels here).
  for (const double readout_s : {0.03, -0.03}) {
    SCOPED_TRACE(readout_s);
    const Eigen::Vector3d w(1.6, -2.2, 1.2);
    const std::vector<uint8_t> sheared = rolling_shutter_image(k, w, readout_s);
    std::vector<uint8_t> unwarped(sheared.size());
    slam::unwarp_colour(sheared.data(), k, motion_over(w, kInterval), kInterval, readout_s, unwarped.data());
    const double before = mean_difference(sheared, global, 8), after = mean_difference(unwarped, global, 8);
    EXPECT_GT(before, 5.0);
    EXPECT_LT(after, 1.0) << "before " << before;
    // Turned the wrong way, the shear doubles.
    slam::unwarp_colour(sheared.data(), k, motion_over(w, kInterval), kInterval, -readout_s, unwarped.data());
    EXPECT_GT(mean_difference(unwarped, global, 8), before);
  }
}

TEST(RollingShutter, NoTurnOrNoReadoutLeavesTheImageAsItIs) {
  const Intrinsics k = small_camera();
  const Eigen::Vector3d w(1.6, -2.2, 1.2);
  const std::vector<uint8_t> img = rolling_shutter_image(k, w, 0.03);
  std::vector<uint8_t> out(img.size());
  slam::unwarp_colour(img.data(), k, motion_over(w, kInterval), kInterval, 0.0, out.data());
  EXPECT_EQ(out, img);
  Eigen::Isometry3d translation_only = Eigen::Isometry3d::Identity();
  translation_only.translation() = Eigen::Vector3d(0.05, 0, 0);
  slam::unwarp_colour(img.data(), k, translation_only, kInterval, 0.03, out.data());
  EXPECT_EQ(out, img);
}

// Rays that leave the image are black; the middle row itself is hardly moved.
TEST(RollingShutter, RaysFromOutsideTheImageAreBlackAndTheMiddleRowStays) {
  const Intrinsics k = small_camera();
  const std::vector<uint8_t> img = rolling_shutter_image(k, Eigen::Vector3d::Zero(), 0.0);
  std::vector<uint8_t> out(img.size());
  const Eigen::Vector3d yaw(0, 6.0, 0);  // the first and last rows turn by 5 degrees
  slam::unwarp_colour(img.data(), k, motion_over(yaw, kInterval), kInterval, 0.03, out.data());
  const auto black = [&](int u, int v) {
    const uint8_t* px = &out[(size_t(v) * kWidth + u) * 3];
    return px[0] == 0 && px[1] == 0 && px[2] == 0;
  };
  int black_first_row = 0;
  for (int u = 0; u < kWidth; ++u) black_first_row += black(u, 0);
  EXPECT_GT(black_first_row, 10);
  const int middle = kHeight / 2;
  for (int u = 0; u < kWidth; ++u)
    for (int c = 0; c < 3; ++c) {
      const size_t i = (size_t(middle) * kWidth + u) * 3 + c;
      ASSERT_LE(std::abs(int(out[i]) - int(img[i])), 3) << "column " << u;
    }
  const Eigen::Matrix3d R = slam::row_rotation(middle, kHeight, yaw, 0.03);
  EXPECT_LT(Eigen::AngleAxisd(R).angle(), 0.03 * 6.0 / kHeight);  // half a row's turn at most
}

// ColourUnwarper: the readout from the input unless the parameters set one, the interval from the
// frame times (the two frames the last motion spans), and the input itself without a motion or a
// readout.
TEST(RollingShutter, ColourUnwarperTakesReadoutAndIntervalFromTheInput) {
  const Intrinsics k = small_camera();
  const Eigen::Vector3d w(1.6, -2.2, 1.2);
  const std::vector<uint8_t> img = rolling_shutter_image(k, w, 0.03);
  const auto expect_unwarped = [&](slam::ColourUnwarper& u, double interval_s, double readout_s, const char* what) {
    std::vector<uint8_t> expected(img.size());
    slam::unwarp_colour(img.data(), k, motion_over(w, kInterval), interval_s, readout_s, expected.data());
    const uint8_t* out = u.unwarp(img.data(), k, motion_over(w, kInterval), true);
    EXPECT_NE(out, img.data()) << what;
    EXPECT_EQ(std::vector<uint8_t>(out, out + img.size()), expected) << what;
  };
  slam::ColourUnwarper from_input;
  EXPECT_EQ(from_input.unwarp(img.data(), k, motion_over(w, kInterval), true), img.data()) << "no readout yet";
  from_input.note_frame_time(1.0, 0.03);
  EXPECT_EQ(from_input.unwarp(img.data(), k, motion_over(w, kInterval), false), img.data()) << "no motion";
  Eigen::Isometry3d translation_only = Eigen::Isometry3d::Identity();
  translation_only.translation() = Eigen::Vector3d(0.05, 0, 0);
  EXPECT_EQ(from_input.unwarp(img.data(), k, translation_only, true), img.data()) << "no turn";
  expect_unwarped(from_input, 1.0 / 30.0, 0.03, "one frame time: the nominal interval");
  from_input.note_frame_time(1.05, 0.03);
  from_input.note_frame_time(1.09, 0.03);
  expect_unwarped(from_input, 0.05, 0.03, "the last motion spans the two frames before this one");
  from_input.note_frame_time(1.12, 0.03);
  expect_unwarped(from_input, 0.04, 0.03, "the next frame's");

  slam::RollingShutterParams global;
  global.colour_readout_s = 0.0;
  slam::ColourUnwarper overridden(global);
  overridden.note_frame_time(1.0, 0.03);
  EXPECT_EQ(overridden.unwarp(img.data(), k, motion_over(w, kInterval), true), img.data()) << "a global shutter";
  slam::RollingShutterParams bottom_up;
  bottom_up.colour_readout_s = -0.02;
  bottom_up.nominal_frame_interval_s = 0.1;
  slam::ColourUnwarper set(bottom_up);
  set.note_frame_time(0.0, 0.03);
  expect_unwarped(set, 0.1, -0.02, "the parameters' readout and nominal interval");
}

}  // namespace
}  // namespace cofusion::test
