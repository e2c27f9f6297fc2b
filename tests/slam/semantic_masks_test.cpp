// Semantic instance masks in the pipeline (semantic_masks.h): excluded classes are never modelled,
// fused or tracked with.
#include <gtest/gtest.h>

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

TEST_F(SemanticScenes, ExcludedPeopleAreNeitherModelledNorFused) {
  const synthetic::SyntheticSequence seq(synthetic::load_scene("walking_people"), 0, 30);
  CoFusion slam(ctx(), seq.intrinsics(), {});
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
