// Semantic instance masks in the pipeline (semantic_masks.h): excluded classes are never modelled,
// fused or tracked with.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <opencv2/core.hpp>

#include "common/error.h"
#include "eval/trajectory_metrics.h"
#include "slam/co_fusion.h"
#include "slam/semantic_masks.h"
#include "support/gpu_fixture.h"
#include "synthetic/synthetic_source.h"

namespace cofusion::test {
namespace {
using slam::CoFusion;
using slam::SemanticFrame;

// The masks of a generated frame as the pipeline takes them.
SemanticFrame semantic_frame(const Frame& frame) {
  SemanticFrame s;
  s.ids.assign(frame.mask.begin<uint16_t>(), frame.mask.end<uint16_t>());
  if (frame.mask_classes) s.classes = frame.mask_classes->name_by_id;
  return s;
}

// The excluded pixels' margin: every pixel within r (Chebyshev) of a set one, clipped at the
// image's edges, against a brute-force reference over sizes and radii.
TEST(SemanticMasks, GrowMaskSetsEveryPixelWithinTheRadius) {
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {7, 5}, {1, 9}, {13, 1}, {31, 17}})
    for (int r : {0, 1, 2, 4, 40}) {
      std::vector<uint8_t> mask(size_t(w) * h, 0);
      for (size_t i = 0; i < mask.size(); ++i) mask[i] = (i * 2654435761u) % 23 == 0;  // sparse seeds
      mask[0] = 1;
      std::vector<uint8_t> expected(mask.size(), 0);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int v = std::max(0, y - r); v <= std::min(h - 1, y + r); ++v)
            for (int u = std::max(0, x - r); u <= std::min(w - 1, x + r); ++u) expected[size_t(y) * w + x] |= mask[size_t(v) * w + u];
      const size_t count = slam::grow_mask(mask, w, r);
      EXPECT_EQ(mask, expected) << w << "x" << h << " r " << r;
      EXPECT_EQ(count, size_t(std::count(expected.begin(), expected.end(), 1)));
    }
  std::vector<uint8_t> odd(10, 0);
  EXPECT_THROW(slam::grow_mask(odd, 3, 1), Error);
}

TEST(SemanticMasks, ExcludedPixelsAreThoseOfExcludedClasses) {
  SemanticFrame f;
  f.ids = {0, 1, 2, 3, 1, 7};
  f.classes = {{1, "person"}, {2, "can"}, {3, "dog"}};  // 7 has no class
  slam::SemanticParams p;
  std::vector<uint8_t> excluded;
  EXPECT_EQ(slam::excluded_pixels(f, p, excluded), 2u);
  EXPECT_EQ(excluded, (std::vector<uint8_t>{0, 1, 0, 0, 1, 0}));
  p.exclude = {"dog", "can"};
  EXPECT_EQ(slam::excluded_pixels(f, p, excluded), 2u);
  EXPECT_EQ(excluded, (std::vector<uint8_t>{0, 0, 1, 1, 0, 0}));
  p.exclude = {};
  EXPECT_EQ(slam::excluded_pixels(f, p, excluded), 0u);
  EXPECT_TRUE(excluded.empty());
  p.exclude = {"person"};
  p.classes = {"can", "person"};
  EXPECT_TRUE(slam::is_modelled_class(p, "can"));
  EXPECT_FALSE(slam::is_modelled_class(p, "person"));  // excluded wins
  EXPECT_FALSE(slam::is_modelled_class(p, "dog"));
  p.classes = {};
  EXPECT_TRUE(slam::is_modelled_class(p, "dog"));
  EXPECT_THROW(slam::check_semantic_frame(f, 7), Error);
  EXPECT_EQ(slam::parse_segmentation_mode("both"), slam::SegmentationMode::kBoth);
  EXPECT_FALSE(slam::parse_segmentation_mode("semantics"));
}

// A 40x30 camera (fx 30) and masks of that size with a box (id 5) at rows 8-15, columns 10-19.
Intrinsics carry_camera() {
  Intrinsics k;
  k.width = 40, k.height = 30, k.fx = k.fy = 30, k.cx = 19.5, k.cy = 14.5;
  return k;
}
SemanticFrame masks_with_a_box(const Intrinsics& k) {
  SemanticFrame made;
  made.ids.assign(size_t(k.width) * size_t(k.height), 0);
  for (int y = 8; y < 16; ++y)
    for (int x = 10; x < 20; ++x) made.ids[size_t(y * k.width + x)] = 5;
  return made;
}

// Masks made from an earlier frame are carried to the current one by the camera's motion: a
// sideways step of the camera over a wall 2 m away shifts them by fx * step / depth pixels; pixels
// without depth, or seeing what the earlier frame did not, get no instance.
TEST(SemanticMasks, CarriedMasksFollowTheCameraMotion) {
  const Intrinsics k = carry_camera();
  const size_t n = size_t(k.width) * size_t(k.height);
  SemanticFrame made = masks_with_a_box(k);
  made.classes = {{5, "box"}, {7, "person"}};
  made.age_frames = 2;
  made.repeated = true;
  for (int y = 0; y < k.height; ++y) made.ids[size_t(y * k.width + k.width - 1)] = 7;  // the right column
  std::vector<float> depth_m(n, 2.0f);
  depth_m[size_t(10 * k.width + 12)] = 0.0f;  // no reading inside the box

  const SemanticFrame same = slam::carry_semantic_frame(made, depth_m.data(), k, Eigen::Isometry3d::Identity());
  EXPECT_EQ(same.classes, made.classes);
  EXPECT_EQ(same.age_frames, 2);
  EXPECT_TRUE(same.repeated);
  for (size_t i = 0; i < n; ++i) EXPECT_EQ(same.ids[i], depth_m[i] > 0 ? made.ids[i] : 0) << i;

  // The current camera stands 0.2 m to the right of the one the masks were made from: a point
  // seen at column u now was at column u + 30 * 0.2 / 2 = u + 3 then.
  Eigen::Isometry3d T_made_current = Eigen::Isometry3d::Identity();
  T_made_current.translation() = Eigen::Vector3d(0.2, 0, 0);
  const SemanticFrame moved = slam::carry_semantic_frame(made, depth_m.data(), k, T_made_current);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const size_t i = size_t(y * k.width + x);
      const uint16_t expected = depth_m[i] <= 0 || x + 3 >= k.width ? 0 : made.ids[size_t(y * k.width + x + 3)];
      EXPECT_EQ(moved.ids[i], expected) << x << "," << y;
    }
  EXPECT_EQ(moved.ids[size_t(8 * k.width + 7)], 5);         // the box's left edge moved from 10 to 7
  EXPECT_EQ(moved.ids[size_t(8 * k.width + 16)], 5);        // its right edge from 19 to 16
  EXPECT_EQ(moved.ids[size_t(8 * k.width + 17)], 0);
  EXPECT_EQ(moved.ids[size_t(3 * k.width + k.width - 4)], 7);  // the person column moved to 36
  EXPECT_EQ(moved.ids[size_t(3 * k.width + k.width - 1)], 0);  // not seen by the earlier camera

  SemanticFrame wrong_size = made;
  wrong_size.ids.pop_back();
  EXPECT_THROW(slam::carry_semantic_frame(wrong_size, depth_m.data(), k, T_made_current), Error);
}

// Masks from the previous frame follow an object model that moved since: where the previous
// labels give a pixel to the object's slot, its own motion carries it; elsewhere the camera's.
TEST(SemanticMasks, CarriedMasksFollowAnObjectsOwnMotion) {
  const Intrinsics k = carry_camera();
  const size_t n = size_t(k.width) * size_t(k.height);
  SemanticFrame made = masks_with_a_box(k);  // the box moves right
  made.classes = {{5, "box"}, {6, "cup"}};
  made.age_frames = 1;
  for (int y = 20; y < 24; ++y)
    for (int x = 30; x < 34; ++x) made.ids[size_t(y * k.width + x)] = 6;  // a cup on the background
  const std::vector<float> depth_m(n, 2.0f);
  // The previous labels: slot 3 around the box (its model's footprint), the background elsewhere.
  std::vector<uint8_t> owner(n, 0);
  for (int y = 6; y < 18; ++y)
    for (int x = 8; x < 26; ++x) owner[size_t(y * k.width + x)] = 3;
  // The box moved 0.2 m right (3 pixels at 2 m): its point at column u now was at u - 3 then.
  Eigen::Isometry3d T_box = Eigen::Isometry3d::Identity();
  T_box.translation() = Eigen::Vector3d(-0.2, 0, 0);
  const SemanticFrame carried =
      slam::carry_semantic_frame(made, depth_m.data(), k, Eigen::Isometry3d::Identity(), owner, {{3, T_box}});
  const auto id_at = [&](int x, int y) { return carried.ids[size_t(y * k.width + x)]; };
  EXPECT_EQ(id_at(12, 10), 0) << "the box's old left edge is empty now";
  EXPECT_EQ(id_at(13, 10), 5);
  EXPECT_EQ(id_at(22, 10), 5) << "its right edge moved from 19 to 22";
  EXPECT_EQ(id_at(23, 10), 0);
  EXPECT_EQ(id_at(30, 20), 6) << "the background's instance follows the camera (still)";
  EXPECT_EQ(id_at(33, 23), 6);
  // Without the owner map everything follows the camera, as before.
  const SemanticFrame still = slam::carry_semantic_frame(made, depth_m.data(), k, Eigen::Isometry3d::Identity());
  EXPECT_EQ(still.ids, made.ids);
  EXPECT_THROW(slam::carry_semantic_frame(made, depth_m.data(), k, Eigen::Isometry3d::Identity(),
                                          std::vector<uint8_t>(n - 1, 0), {{3, T_box}}),
               Error);
}

TEST(SemanticMasks, ClassVotesGiveTheMostVotedClassAndItsShare) {
  slam::ClassVotes v;
  EXPECT_FALSE(v.best());
  v.add("can", 3);
  v.add("cup");
  EXPECT_EQ(v.best()->first, "can");
  EXPECT_DOUBLE_EQ(v.best()->second, 0.75);
  slam::ClassVotes w;
  w.add("cup", 4);
  v.merge(w);
  EXPECT_EQ(v.best()->first, "cup");
  EXPECT_DOUBLE_EQ(v.best()->second, 5.0 / 8.0);
}

TEST(SemanticMasks, InstanceCandidatesAreFollowedByOverlap) {
  // A 10x1 image: an instance moving right by one pixel per frame keeps its count; one that jumps
  // away starts again.
  const auto instance = [](size_t from, size_t to) {
    slam::MaskInstance m;
    for (size_t i = from; i < to; ++i) m.pixels.push_back(i);
    return m;
  };
  slam::InstanceCandidates c;
  const slam::MaskInstance a0 = instance(0, 4), a1 = instance(1, 5), b = instance(7, 10);
  const std::vector<std::optional<Eigen::Vector3d>> at{Eigen::Vector3d(1, 0, 1), Eigen::Vector3d(2, 0, 1)};
  auto seen = c.update({&a0}, {at[0]}, 10);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].frames, 1);
  EXPECT_FALSE(seen[0].previous_centroid);
  seen = c.update({&a1, &b}, at, 10);
  EXPECT_EQ(seen[0].frames, 2);
  ASSERT_TRUE(seen[0].previous_centroid);
  EXPECT_EQ(*seen[0].previous_centroid, Eigen::Vector3d(1, 0, 1));
  EXPECT_EQ(seen[1].frames, 1);
  seen = c.update({&a0}, {at[0]}, 10);  // a0 overlaps a1 by 3 of 4 pixels
  EXPECT_EQ(seen[0].frames, 3);
  seen = c.update({&b}, {at[1]}, 10);
  EXPECT_EQ(seen[0].frames, 1);
}

class SemanticScenes : public GpuTest {};

// walking_people's first frames: two people walk through the room in front of and behind the
// table. With their masks (class person, excluded by default) no model spawns, no pixel of a
// person is labelled as any model, and the camera is tracked from the room alone.
// Person pixels labelled as some model, per frame, without exclusion: motion segmentation alone
// gives much of them to models (what the test below needs the masks for).
TEST_F(SemanticScenes, WithoutExclusionPeopleAreLabelledAsModels) {
  const synthetic::SyntheticSequence seq(synthetic::load_scene("walking_people"), 0, 30);
  slam::CoFusionParams params;
  params.semantic.exclude = {};
  CoFusion slam(ctx(), seq.intrinsics(), params);
  int labelled = 0;
  for (int f = 0; f < seq.size(); ++f) {
    const Frame frame = seq.frame(f);
    const SemanticFrame masks = semantic_frame(frame);
    const slam::CoFusionFrame r = slam.process(frame.depth_m.ptr<float>(), frame.rgb.data, &masks);
    for (size_t i = 0; i < masks.ids.size(); ++i)
      if (const auto c = masks.classes.find(masks.ids[i]); c != masks.classes.end() && c->second == "person")
        labelled += r.labels[i] != 0xFFFF;
  }
  std::printf("  person pixels labelled as a model without exclusion: %d\n", labelled);
  EXPECT_GT(labelled, 0);
}

class ExcludedPeople : public SemanticScenes, public ::testing::WithParamInterface<slam::SegmentationMode> {};

TEST_P(ExcludedPeople, AreNeitherModelledNorFused) {
  const synthetic::SyntheticSequence seq(synthetic::load_scene("walking_people"), 0, 30);
  slam::CoFusionParams params;
  params.semantic.mode = GetParam();
  CoFusion slam(ctx(), seq.intrinsics(), params);
  Trajectory camera;
  int person_pixels = 0;
  for (int f = 0; f < seq.size(); ++f) {
    const Frame frame = seq.frame(f);
    const SemanticFrame masks = semantic_frame(frame);
    const slam::CoFusionFrame r = slam.process(frame.depth_m.ptr<float>(), frame.rgb.data, &masks);
    camera.push_back({seq.timestamp_s(f), r.T_world_camera});
    EXPECT_EQ(r.active.size(), 1u) << "frame " << f;
    for (const auto& e : r.events) ADD_FAILURE() << e;
    int labelled = 0;
    for (size_t i = 0; i < masks.ids.size(); ++i) {
      const auto c = masks.classes.find(masks.ids[i]);
      if (c == masks.classes.end() || c->second != "person") continue;
      ++person_pixels;
      labelled += r.labels[i] != 0xFFFF;
    }
    EXPECT_EQ(labelled, 0) << "frame " << f;
  }
  std::printf("  person pixels: %d\n", person_pixels);
  EXPECT_GT(person_pixels, 30 * 640 * 480 / 50) << "the people are in view";
  for (const auto& m : slam.models()) EXPECT_EQ(m.id, 0) << "model " << m.id << " (" << m.class_name << ")";
  EXPECT_LE(eval::compute_ate(seq.camera_trajectory(), camera).translation_m.rmse, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Modes, ExcludedPeople,
                         ::testing::Values(slam::SegmentationMode::kMotion, slam::SegmentationMode::kBoth),
                         [](const auto& mode) { return std::string(slam::to_string(mode.param)); });

// First frame from which object `id` (1-based) lies fully inside the image (its ground-truth mask
// has pixels and none on the image border), or -1.
int fully_in_view_from(const synthetic::SyntheticSequence& seq, int id, int from = 0) {
  for (int f = from; f < seq.size(); ++f) {
    const cv::Mat ids = seq.render(f).instance_ids;
    bool any = false, border = false;
    for (int y = 0; y < ids.rows; ++y)
      for (int x = 0; x < ids.cols; ++x)
        if (ids.at<uint16_t>(y, x) == id) {
          any = true;
          border = border || x == 0 || y == 0 || x == ids.cols - 1 || y == ids.rows - 1;
        }
    if (any && !border) return f;
  }
  return -1;
}

// table_placement's box, can and ball are carried in and put on the table; in semantic mode with
// the scene's own masks each becomes a model (although none moves relative to the camera in a
// way motion segmentation would need) within 3 frames of being fully in view, with its class.
void expect_objects_modelled(const synthetic::SyntheticSequence& seq, const std::vector<slam::CoFusionFrame>& frames,
                             const std::vector<slam::ModelSnapshot>& models, const std::vector<int>& objects) {
  for (int id : objects) {
    const std::string cls = *seq.mask_classes()->find(uint16_t(id));
    const int in_view = fully_in_view_from(seq, id);
    ASSERT_GE(in_view, 0) << cls << " never fully in view";
    const int check = std::min(in_view + 3, seq.size() - 1);
    const cv::Mat gt = seq.render(check).instance_ids;
    std::map<uint16_t, int> covered;
    for (int i = 0; i < gt.rows * gt.cols; ++i)
      if (gt.at<uint16_t>(i / gt.cols, i % gt.cols) == id) ++covered[frames[size_t(check)].labels[size_t(i)]];
    int best_model = -1, best = 0;
    for (const auto& [model, pixels] : covered)
      if (model != 0 && model != 0xFFFF && pixels > best) best = pixels, best_model = model;
    ASSERT_GT(best_model, 0) << cls << ": no model labels it at frame " << check << " (fully in view from " << in_view << ")";
    const auto m = std::find_if(models.begin(), models.end(), [&](const auto& s) { return s.id == best_model; });
    ASSERT_NE(m, models.end()) << cls;
    EXPECT_EQ(m->class_name, cls) << "model " << best_model;
    EXPECT_GT(m->class_confidence, 0.5) << "model " << best_model;
    EXPECT_LE(m->first_frame, check) << cls;
  }
}

// Runs `seq` in semantic mode with its own masks and checks that each of `objects` is modelled.
void expect_semantic_mode_models(gpu::Context& ctx, const synthetic::SyntheticSequence& seq, const std::vector<int>& objects) {
  slam::CoFusionParams params;
  params.semantic.mode = slam::SegmentationMode::kSemantic;
  CoFusion slam(ctx, seq.intrinsics(), params);
  std::vector<slam::CoFusionFrame> frames;
  for (int f = 0; f < seq.size(); ++f) {
    const Frame frame = seq.frame(f);
    const SemanticFrame masks = semantic_frame(frame);
    frames.push_back(slam.process(frame.depth_m.ptr<float>(), frame.rgb.data, &masks));
    for (const auto& e : frames.back().events) std::printf("  %s\n", e.c_str());
  }
  expect_objects_modelled(seq, frames, slam.models(), objects);
}

TEST_F(SemanticScenes, TablePlacementInstancesBecomeModelsOfTheirClassSlow) {
  const synthetic::SyntheticSequence seq(synthetic::load_scene("table_placement"));
  expect_semantic_mode_models(ctx(), seq, {1, 2, 3});
}

// The box alone (its first 50 frames): fast enough for every run.
TEST_F(SemanticScenes, CarriedInBoxBecomesABoxModelInSemanticMode) {
  const synthetic::SyntheticSequence seq(synthetic::load_scene("table_placement"), 0, 50);
  expect_semantic_mode_models(ctx(), seq, {1});
}

// one_object's box lies still on the table for 15 frames, then slides off turning. In both mode
// with the scene's masks it becomes a box model at once, resting (its world pose held, the
// background keeps its surfels); it wakes when the background no longer explains its pixels and
// is tracked from then on, its surfels gone from the background.
TEST_F(SemanticScenes, ARecognisedBoxRestsUntilItMovesThenIsTracked) {
  const synthetic::SyntheticSequence seq(synthetic::load_scene("one_object"), 0, 45);
  slam::CoFusionParams params;
  params.semantic.mode = slam::SegmentationMode::kBoth;
  CoFusion slam(ctx(), seq.intrinsics(), params);
  Trajectory camera;
  int spawned = -1, woke = -1;
  std::vector<slam::CoFusionFrame> frames;
  for (int f = 0; f < seq.size(); ++f) {
    const Frame frame = seq.frame(f);
    const SemanticFrame masks = semantic_frame(frame);
    frames.push_back(slam.process(frame.depth_m.ptr<float>(), frame.rgb.data, &masks));
    camera.push_back({seq.timestamp_s(f), frames.back().T_world_camera});
    for (const auto& e : frames.back().events) {
      std::printf("  %s\n", e.c_str());
      if (e.find("spawned model 1 from a box instance") != std::string::npos && e.find("resting") != std::string::npos)
        spawned = f;
      if (e.find("model 1 started moving") != std::string::npos) woke = f;
    }
  }
  int first_motion = 1;
  while (seq.T_world_object(1, first_motion)->isApprox(*seq.T_world_object(1, 0), 1e-9)) ++first_motion;
  ASSERT_GE(spawned, 0) << "the box became a resting model";
  EXPECT_LE(spawned, 2);
  ASSERT_GT(woke, 0) << "the box model woke";
  EXPECT_GE(woke, first_motion) << "not before the box moved (from frame " << first_motion << ")";
  EXPECT_LE(woke, first_motion + 8) << "the box moves from frame " << first_motion;

  const auto models = slam.models();
  const auto box = std::find_if(models.begin(), models.end(), [](const auto& m) { return m.id == 1; });
  ASSERT_NE(box, models.end());
  EXPECT_EQ(box->class_name, "box");
  EXPECT_EQ(models.size(), 2u) << "the background and the box";
  // While it rested its world pose did not change; since it woke it followed the box: its motion
  // from the first frame to the last carries the box's centre where the true motion does.
  const Eigen::Isometry3d T_first = box->trajectory.front().second;
  for (const auto& [f, T] : box->trajectory) {
    if (f >= woke) break;
    EXPECT_TRUE(T.isApprox(T_first, 1e-12)) << "frame " << f;
  }
  // The tracker's world is the first camera's: the true motion is taken there.
  const Eigen::Isometry3d T_scene_slam = seq.T_world_camera(0);
  const auto true_motion = [&](int f) {
    return T_scene_slam.inverse() * *seq.T_world_object(1, f) * seq.T_world_object(1, 0)->inverse() * T_scene_slam;
  };
  const Eigen::Vector3d centre = T_scene_slam.inverse() * seq.T_world_object(1, 0)->translation();
  const int last = seq.size() - 1;
  const Eigen::Isometry3d model_motion = box->trajectory.back().second * T_first.inverse();
  const double drift_m = (model_motion * centre - true_motion(last) * centre).norm();
  std::printf("  box centre off by %.1f mm after %.0f mm of travel\n", 1000 * drift_m,
              1000 * (true_motion(last) * centre - centre).norm());
  EXPECT_LE(drift_m, 0.02);
  // It was tracked in the very frame it woke (SemanticParams::track_woken), so its pose there
  // already follows the box, which moved while the model was held at rest.
  const auto at_wake = std::find_if(box->trajectory.begin(), box->trajectory.end(), [&](const auto& p) { return p.first == woke; });
  ASSERT_NE(at_wake, box->trajectory.end());
  const double wake_off_m = ((at_wake->second * T_first.inverse()) * centre - true_motion(woke) * centre).norm();
  const double rest_off_m = (true_motion(woke) * centre - centre).norm();
  std::printf("  at its wake (frame %d) the box centre is off by %.1f mm; %.1f mm at its rest pose\n", woke,
              1000 * wake_off_m, 1000 * rest_off_m);
  EXPECT_LT(wake_off_m, 0.5 * rest_off_m);
  EXPECT_LE(eval::compute_ate(seq.camera_trajectory(), camera).translation_m.rmse, 0.01);
  // The last frame's box pixels are the box model's.
  const cv::Mat gt = seq.render(seq.size() - 1).instance_ids;
  size_t inter = 0, uni = 0;
  for (int i = 0; i < gt.rows * gt.cols; ++i) {
    const bool a = gt.ptr<uint16_t>()[i] == 1, b = frames.back().labels[size_t(i)] == 1;
    inter += a && b;
    uni += a || b;
  }
  EXPECT_GE(double(inter) / double(uni), 0.85);
}

TEST_F(SemanticScenes, RejectsMasksOfAnotherSize) {
  const synthetic::SyntheticSequence seq(synthetic::load_scene("static_room"), 0, 1);
  CoFusion slam(ctx(), seq.intrinsics(), {});
  const Frame frame = seq.frame(0);
  SemanticFrame masks;
  masks.ids.assign(10, 0);
  EXPECT_THROW(slam.process(frame.depth_m.ptr<float>(), frame.rgb.data, &masks), Error);
}

}  // namespace
}  // namespace cofusion::test
