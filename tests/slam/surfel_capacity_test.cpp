// A model's capacity limit (FusionParams::max_surfels, the device's largest buffer): the least
// confident surfels are culled and the run goes on, with tracking intact.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <tuple>

#include "eval/trajectory_metrics.h"
#include "slam/co_fusion.h"
#include "slam/surfel_model.h"
#include "support/gpu_fixture.h"
#include "synthetic/synthetic_source.h"

namespace cofusion::test {
namespace {
using ::testing::HasSubstr;

Surfel surfel(float confidence, int last_seen, int created = 0, float x = 0) {
  Surfel s{};
  s.px = x;
  s.confidence = confidence;
  s.last_seen_frame = last_seen;
  s.created_frame = created;
  return s;
}

// (confidence, last seen, created, x): the order keep_most_confident keeps by, plus an identity.
auto key(const Surfel& s) { return std::make_tuple(s.confidence, s.last_seen_frame, s.created_frame, s.px); }

std::vector<Surfel> sorted(std::vector<Surfel> v) {
  std::sort(v.begin(), v.end(), [](const Surfel& a, const Surfel& b) { return key(a) > key(b); });
  return v;
}

TEST(KeepMostConfident, KeepsTheHighestConfidencesTiesGoingToTheMostRecentlySeen) {
  std::vector<Surfel> v = {surfel(1, 5, 0, 1), surfel(7, 1, 0, 2), surfel(3, 2, 0, 3), surfel(3, 9, 0, 4),
                           surfel(3, 9, 4, 5), surfel(0.5f, 10, 0, 6)};
  slam::keep_most_confident(v, 3);
  ASSERT_EQ(v.size(), 3u);
  const auto kept = sorted(v);
  EXPECT_EQ(kept[0].px, 2);  // confidence 7
  EXPECT_EQ(kept[1].px, 5);  // confidence 3, seen at 9, created at 4
  EXPECT_EQ(kept[2].px, 4);  // confidence 3, seen at 9, created at 0
  std::vector<Surfel> few = {surfel(1, 0), surfel(2, 0)};
  slam::keep_most_confident(few, 5);
  EXPECT_EQ(few.size(), 2u) << "nothing to cull";
  slam::keep_most_confident(few, 0);
  EXPECT_TRUE(few.empty());
}

std::vector<Surfel> random_surfels(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> confidence(0.0f, 20.0f);
  std::uniform_int_distribution<int> frame(0, 100);
  std::vector<Surfel> v;
  for (size_t i = 0; i < n; ++i) v.push_back(surfel(confidence(rng), frame(rng), frame(rng), float(i)));
  return v;
}

class SurfelCapacity : public GpuTest {};

TEST_F(SurfelCapacity, CullOnTheDeviceKeepsWhatTheHostReferenceKeeps) {
  slam::SurfelModel model(ctx(), 3, 1024);
  const std::vector<Surfel> all = random_surfels(5000, 7);
  model.upload(stream(), all);
  EXPECT_EQ(model.cull_least_confident(stream(), 1234), 5000u - 1234u);
  EXPECT_EQ(model.count(), 1234u);
  EXPECT_EQ(model.culled_total(), 5000u - 1234u);
  std::vector<Surfel> expected = all;
  slam::keep_most_confident(expected, 1234);
  const auto kept = sorted(model.download(stream())), want = sorted(expected);
  ASSERT_EQ(kept.size(), want.size());
  for (size_t i = 0; i < kept.size(); ++i) ASSERT_EQ(key(kept[i]), key(want[i])) << i;
  EXPECT_EQ(model.cull_least_confident(stream(), 2000), 0u) << "under the target: nothing culled";
}

TEST_F(SurfelCapacity, LimitIsTheCapAndTheDevicesRoomLessOneFrame) {
  slam::SurfelModel model(ctx(), 0, 1024);
  const unsigned max = model.max_capacity();
  EXPECT_EQ(model.limit(100, 0), max - 100);
  EXPECT_EQ(model.limit(100, 4000), 4000u);
  EXPECT_EQ(model.limit(100, max), max - 100) << "the device's limit wins when it is lower";
  EXPECT_EQ(model.limit(max + 1, 0), 0u);
}

TEST_F(SurfelCapacity, MakeRoomCullsAnOverfullModelToTheKeepFractionAndGrowsForTheFrame) {
  slam::SurfelModel model(ctx(), 0, 1024);
  model.upload(stream(), random_surfels(5000, 11));
  slam::FusionParams params;
  params.max_surfels = 4000;
  params.cull_keep_fraction = 0.5f;
  EXPECT_EQ(model.make_room(stream(), 3000, params), 3000u);
  EXPECT_EQ(model.count(), 2000u);
  EXPECT_GE(model.capacity(), 2000u + 3000u) << "room for the frame's new surfels";
  EXPECT_EQ(model.make_room(stream(), 3000, params), 0u) << "within the cap: nothing culled";
}

// A small cap on a whole run: the count never exceeds it, one warning, tracking as good.
TEST_F(SurfelCapacity, CappedCoFusionRunKeepsGoingWithinTheCapAndKeepsTracking) {
  synthetic::SceneDescription scene = synthetic::load_scene("static_room");
  scene.camera.intrinsics = scene.camera.intrinsics.at_level(1);  // 320x240: a quicker test
  const synthetic::SyntheticSequence seq(scene, 0, 40);
  slam::CoFusionParams params;
  // Uncapped, this model holds 75000-86000 surfels over these frames (camera ATE 3.8 mm); capped
  // at 30000 the fusion culls in most frames (4.2 mm).
  constexpr unsigned kCap = 30000;
  params.slam.fusion.max_surfels = kCap;
  slam::CoFusion slam(ctx(), seq.intrinsics(), params);
  Trajectory camera;
  std::vector<std::string> warnings;
  unsigned most = 0, last = 0;
  for (int f = 0; f < seq.size(); ++f) {
    const Frame frame = seq.frame(f);
    const slam::CoFusionFrame r = slam.process(frame.depth_m.ptr<float>(), frame.rgb.data);
    camera.push_back({seq.timestamp_s(f), r.T_world_camera});
    EXPECT_EQ(r.camera_state, slam::CameraState::kTracking) << "frame " << f;
    ASSERT_EQ(r.active.size(), 1u) << "frame " << f;
    last = r.active[0].surfels;
    most = std::max(most, last);
    EXPECT_LE(last, kCap) << "frame " << f;
    for (const auto& e : r.events)
      if (e.find("warning") != std::string::npos) warnings.push_back(e);
  }
  ASSERT_EQ(warnings.size(), 1u) << "one warning, at the first cull";
  EXPECT_THAT(warnings[0], HasSubstr("model 0 reached its limit of 30000 surfels"));
  EXPECT_GT(last, kCap / 2) << "the cull keeps cull_keep_fraction of the cap, fusion refills it";
  EXPECT_LE(eval::compute_ate(seq.camera_trajectory(), camera).translation_m.rmse, 0.006);
}

}  // namespace
}  // namespace cofusion::test
