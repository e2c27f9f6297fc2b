// DenseSlam (the background-only pipeline `bench` times) resamples colour for a rolling shutter as
// CoFusion does: the live intensity it tracks with is that of the colour unwarped by its camera's
// last motion, and a global shutter leaves the colour as it is.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "kernels/preprocess_reference.h"
#include "slam/dense_slam.h"
#include "slam/rolling_shutter.h"
#include "support/gpu_fixture.h"
#include "synthetic/synthetic_source.h"

namespace cofusion::test {
namespace {

class DenseSlamTest : public GpuTest {};

// Mean absolute difference of two intensity images.
double mean_difference(const std::vector<float>& a, const kernels::Image<float>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i) sum += std::abs(a[i] - b.pixels[i]);
  return sum / double(a.size());
}

TEST_F(DenseSlamTest, ResamplesColourForTheRollingShutterByTheLastMotion) {
  const synthetic::SyntheticSequence seq(synthetic::load_scene("static_room"));
  const Intrinsics& k = seq.intrinsics();
  // A long readout, so that the camera's slow turn shears the image visibly.
  constexpr double kReadoutS = 0.5;
  slam::SlamParams sheared_params;
  sheared_params.rolling_shutter.colour_readout_s = kReadoutS;
  slam::DenseSlam sheared(ctx(), k, sheared_params), global(ctx(), k, slam::SlamParams{});
  std::vector<slam::FrameResult> results;
  const size_t n = size_t(k.width) * k.height;
  std::vector<float> intensity(n);
  for (int f = 0; f < 5; ++f) {
    SCOPED_TRACE("frame " + std::to_string(f));
    const Frame frame = seq.frame(f);
    sheared.note_frame_time(seq.timestamp_s(f), 0.0);  // the readout comes from the parameters
    global.note_frame_time(seq.timestamp_s(f), 0.0);
    results.push_back(sheared.process(frame.depth_m.ptr<float>(), frame.rgb.data));
    global.process(frame.depth_m.ptr<float>(), frame.rgb.data);
    const auto as_given = kernels::reference::rgb_to_intensity(frame.rgb.data, k.width, k.height);
    global.stream().download(global.live().levels[0].intensity, intensity.data(), n * sizeof(float));
    EXPECT_LT(mean_difference(intensity, as_given), 1e-3) << "a global shutter's colour is used as it is";
    sheared.stream().download(sheared.live().levels[0].intensity, intensity.data(), n * sizeof(float));
    if (f < 2) {  // no motion to go by yet (the first tracked frame's guess is no motion)
      EXPECT_LT(mean_difference(intensity, as_given), 1e-3);
      continue;
    }
    ASSERT_FALSE(results[f - 1].tracking.failed);
    const Eigen::Isometry3d last_motion = results[f - 2].T_world_camera.inverse() * results[f - 1].T_world_camera;
    std::vector<uint8_t> unwarped(n * 3);
    slam::unwarp_colour(frame.rgb.data, k, last_motion, seq.timestamp_s(f - 1) - seq.timestamp_s(f - 2), kReadoutS,
                        unwarped.data());
    const auto expected = kernels::reference::rgb_to_intensity(unwarped.data(), k.width, k.height);
    EXPECT_LT(mean_difference(intensity, expected), 1e-3);
    EXPECT_GT(mean_difference(intensity, as_given), 3.0) << "the turn must shear the image visibly";
  }
}

}  // namespace
}  // namespace cofusion::test
