// Motion segmentation: unaries, post-processing, and end-to-end cases on synthetic frames.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include <tbb/global_control.h>

#include "segmentation/motion_segmentation.h"
#include "segmentation/segmentation_bench.h"
#include "support/test_support.h"

namespace cofusion::segmentation {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

std::vector<std::span<const float>> spans(const std::vector<std::vector<float>>& costs) {
  return {costs.begin(), costs.end()};
}

// A 40x40 frame split into four 20x20 superpixels (quadrants 0 1 / 2 3), depth 1..3 m.
struct QuadFrame {
  static constexpr int kSize = 40;
  Superpixels sp;
  std::vector<uint8_t> rgb = std::vector<uint8_t>(kSize * kSize * 3, 100);
  std::vector<float> depth_m = std::vector<float>(kSize * kSize, 2.0f);
  QuadFrame() {
    sp.width = sp.height = kSize;
    sp.count = 4;
    sp.step_x_px = sp.step_y_px = 20;
    sp.label.resize(kSize * kSize);
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x) sp.label[static_cast<size_t>(y * kSize + x)] = (y >= 20) * 2 + (x >= 20);
    depth_m[0] = 1.0f;  // depth range 4 m: 1% is 4 cm, capped at no_geometry_cost_max_m (1 cm)
    depth_m[kSize * kSize - 1] = 5.0f;
  }
  std::vector<float> cost_per_quadrant(std::array<float, 4> v) const {
    std::vector<float> c(kSize * kSize);
    for (size_t i = 0; i < c.size(); ++i) c[i] = v[static_cast<size_t>(sp.label[i])];
    return c;
  }
};

TEST(MotionSegmentation, UnariesUseFixedCostWhereAModelHasNoGeometry) {
  QuadFrame f;
  std::vector<std::vector<float>> costs = {f.cost_per_quadrant({0.002f, 0.002f, 0.004f, 0.002f}),
                                           f.cost_per_quadrant({kNaN, kNaN, kNaN, 0.003f})};
  // Quadrant 1: model 1 has costs on 20% of the pixels only (< min_geometry_fraction 0.3).
  for (int y = 0; y < 4; ++y)
    for (int x = 20; x < 40; ++x) costs[1][static_cast<size_t>(y * 40 + x)] = 0.001f;
  MotionSegmenter seg{MotionSegmentationParams{}};
  const auto& u = seg.compute_unaries(f.sp, f.rgb.data(), f.depth_m.data(), spans(costs));
  ASSERT_EQ(u.nodes.size(), 4u);
  EXPECT_NEAR(u.depth_range_m, 4.0f, 1e-6);
  // In units of cost_scale_m: min(1% of 4 m, 1.5 cm) for an object (model 1), min(1% of 4 m,
  // 1 cm) for the background (model 0).
  const float fixed = 0.015f / 0.01f, background_fixed = 0.01f / 0.01f;
  const size_t L = 3;
  EXPECT_NEAR(u.energy[0 * L + 0], 0.2f, 1e-5);
  EXPECT_NEAR(u.energy[2 * L + 0], 0.4f, 1e-5);
  EXPECT_NEAR(u.energy[0 * L + 1], fixed, 1e-5);
  EXPECT_NEAR(u.energy[1 * L + 1], fixed, 1e-5) << "20% coverage is no geometry";
  EXPECT_NEAR(u.energy[2 * L + 1], fixed, 1e-5);
  EXPECT_NEAR(u.energy[3 * L + 1], 0.3f, 1e-5);
  {
    auto without_background = costs;
    without_background[0] = f.cost_per_quadrant({0.002f, 0.002f, 0.004f, kNaN});
    MotionSegmenter seg_b{MotionSegmentationParams{}};
    EXPECT_NEAR(seg_b.compute_unaries(f.sp, f.rgb.data(), f.depth_m.data(), spans(without_background)).energy[3 * L + 0],
                background_fixed, 1e-5);
  }
  // Node features: grid units (20 px step), mean colour and depth.
  EXPECT_NEAR(u.nodes[3].x, (29.5f) / 20.0f, 1e-5);
  EXPECT_NEAR(u.nodes[3].y, (29.5f) / 20.0f, 1e-5);
  EXPECT_NEAR(u.nodes[0].r, 100.0f, 1e-5);
  EXPECT_NEAR(u.nodes[0].depth_m, (399 * 2.0f + 1.0f) / 400.0f, 1e-5);

  // Without the cap the fixed cost is 1% of the range; with a flat frame, the floor.
  MotionSegmentationParams uncapped;
  uncapped.no_geometry_cost_max_m = uncapped.object_no_geometry_cost_max_m = 1.0f;
  MotionSegmenter seg2{uncapped};
  EXPECT_NEAR(seg2.compute_unaries(f.sp, f.rgb.data(), f.depth_m.data(), spans(costs)).energy[0 * L + 1], 4.0f, 1e-5);
  std::fill(f.depth_m.begin(), f.depth_m.end(), 2.0f);
  EXPECT_NEAR(seg2.compute_unaries(f.sp, f.rgb.data(), f.depth_m.data(), spans(costs)).energy[0 * L + 1],
              uncapped.no_geometry_cost_min_m / uncapped.cost_scale_m, 1e-5);
}

TEST(MotionSegmentation, OutlierWinsOnlyWhereEveryModelCostIsHigh) {
  QuadFrame f;
  // Quadrant 0: both models 5 cm. 1: model 1 fits (2 mm). 2: model 0 5 cm, model 1 no geometry.
  // 3: no model has geometry.
  const std::vector<std::vector<float>> costs = {f.cost_per_quadrant({0.05f, 0.05f, 0.05f, kNaN}),
                                                 f.cost_per_quadrant({0.05f, 0.002f, kNaN, kNaN})};
  MotionSegmentationParams p;
  MotionSegmenter seg{p};
  const auto& u = seg.compute_unaries(f.sp, f.rgb.data(), f.depth_m.data(), spans(costs));
  auto best = [&](size_t node) {
    size_t b = 0;
    for (size_t l = 1; l < 3; ++l)
      if (u.energy[node * 3 + l] < u.energy[node * 3 + b]) b = l;
    return b;
  };
  EXPECT_EQ(best(0), 2u) << "nothing explains quadrant 0: outlier";
  EXPECT_EQ(best(1), 1u);
  EXPECT_EQ(best(2), 2u) << "the only model with geometry fails: outlier";
  EXPECT_NE(best(3), 2u) << "no geometry at all is not evidence of motion (even in a 4 m deep frame)";
  EXPECT_NEAR(u.energy[0 * 3 + 2], p.outlier_min_energy, 1e-6);
  EXPECT_NEAR(u.energy[1 * 3 + 2], p.outlier_threshold - 0.2f, 1e-5);
  EXPECT_NEAR(u.energy[3 * 3 + 2], p.outlier_threshold, 1e-6);
}

TEST(MotionSegmentation, SuperpixelsWithoutDepthAreNotLabelled) {
  QuadFrame f;
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 20; ++x) f.depth_m[static_cast<size_t>(y * 40 + x)] = (x + y) % 2 ? 0.0f : kNaN;
  const std::vector<std::vector<float>> costs = {std::vector<float>(40 * 40, 0.002f)};
  MotionSegmentationParams p;
  p.min_component_px = 0;
  MotionSegmenter seg{p};
  const SegmentationResult r = seg.segment(f.sp, f.rgb.data(), f.depth_m.data(), spans(costs));
  EXPECT_EQ(r.crf_node_count, 3);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) {
      const bool no_depth = x < 20 && y < 20;
      EXPECT_EQ(r.labels[static_cast<size_t>(y * 40 + x)], no_depth ? kNoLabel : 0) << x << "," << y;
    }
  EXPECT_EQ(r.model_pixels[0], 1200);

  // No depth anywhere: nothing is labelled, nothing breaks.
  std::fill(f.depth_m.begin(), f.depth_m.end(), 0.0f);
  const SegmentationResult none = seg.segment(f.sp, f.rgb.data(), f.depth_m.data(), spans(costs));
  EXPECT_EQ(none.crf_node_count, 0);
  EXPECT_EQ(none.depth_range_m, 0.0f);
  EXPECT_TRUE(std::all_of(none.labels.begin(), none.labels.end(), [](uint8_t l) { return l == kNoLabel; }));
  EXPECT_TRUE(none.outlier_components.empty());
}

TEST(MotionSegmentation, PostprocessingKeepsLargestObjectComponentAndRemovesSmallOnes) {
  const int w = 60, h = 40;
  std::vector<uint8_t> labels(static_cast<size_t>(w) * h, 0);
  auto fill = [&](int x0, int y0, int x1, int y1, uint8_t v) {
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) labels[static_cast<size_t>(y * w + x)] = v;
  };
  // Model count 2: labels 0 (background), 1 (object), 2 (outlier).
  fill(0, 0, 60, 20, 0);       // background, top half...
  fill(0, 20, 60, 40, 1);      // ...object below, cut in two by background and outlier strips
  fill(20, 20, 24, 40, 0);     // background strip (80 px): splits the object; background is exempt
  fill(24, 20, 26, 40, 2);     // outlier strip (40 px)
  fill(40, 0, 50, 10, 2);      // outlier block (100 px)
  fill(5, 5, 8, 8, 2);         // tiny outlier (9 px): removed
  fill(55, 5, 57, 7, 1);       // tiny object piece (4 px): removed (and not the largest)
  fill(30, 5, 33, 8, kNoLabel);
  MotionSegmentationParams p;
  p.min_component_px = 30;
  MotionSegmenter seg{p};
  SegmentationResult r;
  std::vector<uint8_t> out = labels;
  seg.postprocess(out, w, h, 2, r);
  // Object: left piece 20x20 = 400 px is not the largest; right piece 34x20 = 680 px is kept.
  for (int y = 20; y < 40; ++y) {
    EXPECT_EQ(out[static_cast<size_t>(y * w + 5)], kNoLabel);
    EXPECT_EQ(out[static_cast<size_t>(y * w + 45)], 1);
    EXPECT_EQ(out[static_cast<size_t>(y * w + 21)], 0) << "background strip kept";
  }
  EXPECT_EQ(out[static_cast<size_t>(6 * w + 6)], kNoLabel);
  EXPECT_EQ(out[static_cast<size_t>(6 * w + 56)], kNoLabel);
  EXPECT_EQ(out[static_cast<size_t>(6 * w + 31)], kNoLabel);
  ASSERT_EQ(r.outlier_components.size(), 2u);
  EXPECT_EQ(r.outlier_components[0].pixels, 100);
  EXPECT_EQ(r.outlier_components[0].x0, 40);
  EXPECT_EQ(r.outlier_components[0].y0, 0);
  EXPECT_EQ(r.outlier_components[0].x1, 50);
  EXPECT_EQ(r.outlier_components[0].y1, 10);
  EXPECT_EQ(r.outlier_components[0].label, 2);
  EXPECT_EQ(r.outlier_components[1].pixels, 40);
  ASSERT_EQ(r.model_pixels.size(), 2u);
  EXPECT_EQ(r.model_pixels[1], 680);
  // Background: top half minus outlier block, tiny outlier, tiny object, no-label square, plus
  // the strip; the tiny pieces left holes (they were not background).
  EXPECT_EQ(r.model_pixels[0], 1200 - 100 - 9 - 4 - 9 + 80);
}

// An object's one component is the tracked object, not a candidate: a sliver at the image's edge
// stays the object's down to min_object_component_px, while an outlier region of the same size is
// below min_component_px and removed.
TEST(MotionSegmentation, PostprocessingKeepsAnObjectsSliverButNotAnOutliersOfTheSameSize) {
  const int w = 40, h = 20;
  std::vector<uint8_t> labels(static_cast<size_t>(w * h), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < 4; ++x) labels[static_cast<size_t>(y * w + x)] = 1;  // object sliver, 80 px
  for (int y = 5; y < 15; ++y)
    for (int x = 20; x < 28; ++x) labels[static_cast<size_t>(y * w + x)] = 2;  // outlier, 80 px
  MotionSegmentationParams p;
  p.min_component_px = 1000;
  p.min_object_component_px = 64;
  SegmentationResult r;
  std::vector<uint8_t> out = labels;
  MotionSegmenter{p}.postprocess(out, w, h, 2, r);
  EXPECT_EQ(r.model_pixels[1], 80);
  EXPECT_TRUE(r.outlier_components.empty());
  EXPECT_EQ(out[static_cast<size_t>(10 * w + 24)], kNoLabel);
  EXPECT_EQ(out[static_cast<size_t>(10 * w + 2)], 1);

  p.min_object_component_px = 81;  // one pixel more than the sliver: it goes too
  out = labels;
  MotionSegmenter{p}.postprocess(out, w, h, 2, r);
  EXPECT_EQ(r.model_pixels[1], 0);
  EXPECT_EQ(out[static_cast<size_t>(10 * w + 2)], kNoLabel);
}

TEST(MotionSegmentation, PostprocessingRejectsUnknownLabels) {
  std::vector<uint8_t> labels(16, 3);
  SegmentationResult r;
  MotionSegmenter seg{MotionSegmentationParams{}};
  EXPECT_NE(test::error_of([&] { seg.postprocess(labels, 4, 4, 2, r); }).find("label 3"), std::string::npos);
}

double iou_with_block(const SegmentationResult& r, uint8_t label, const SyntheticSegmentationFrame& f) {
  int64_t inter = 0, uni = 0;
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x) {
      const bool a = r.labels[static_cast<size_t>(y * r.width + x)] == label;
      const bool b = x >= f.moved_x0 && x < f.moved_x1 && y >= f.moved_y0 && y < f.moved_y1;
      inter += a && b;
      uni += a || b;
    }
  return static_cast<double>(inter) / static_cast<double>(uni);
}

// Fraction of the pixels with depth outside `outside` that carry `label`.
template <class Outside>
double fraction_labelled(const SegmentationResult& r, const SyntheticSegmentationFrame& f, uint8_t label, Outside outside) {
  int64_t n = 0, hit = 0;
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x) {
      const size_t i = static_cast<size_t>(y * r.width + x);
      if (!outside(x, y) || !(f.depth_m[i] > 0)) continue;
      ++n;
      hit += r.labels[i] == label;
    }
  return static_cast<double>(hit) / static_cast<double>(n);
}

TEST(MotionSegmentation, MovedBlockBecomesOneOutlierComponent) {
  // Background model fits (~2 mm) everywhere except a 120x100 block that moved (5 cm).
  const SyntheticSegmentationFrame f = make_synthetic_segmentation_frame(640, 480, 1);
  ASSERT_EQ(f.moved_x1 - f.moved_x0, 120);
  ASSERT_EQ(f.moved_y1 - f.moved_y0, 100);
  for (const CrfMethod method : {CrfMethod::kPermutohedral, CrfMethod::kExact}) {
    MotionSegmentationParams p;
    p.crf.method = method;
    MotionSegmenter seg{p};
    const Superpixels sp = seg.superpixels(f.rgb.data(), f.depth_m.data(), f.width, f.height);
    const SegmentationResult r = seg.segment(sp, f.rgb.data(), f.depth_m.data(), spans(f.costs));
    SCOPED_TRACE("method " + std::to_string(static_cast<int>(method)));
    ASSERT_EQ(r.model_count, 1);
    ASSERT_EQ(r.outlier_components.size(), 1u);
    const auto& c = r.outlier_components[0];
    EXPECT_EQ(c.label, 1);
    EXPECT_GT(iou_with_block(r, 1, f), 0.9);
    EXPECT_NEAR(c.x0, f.moved_x0, 4);
    EXPECT_NEAR(c.x1, f.moved_x1, 4);
    EXPECT_NEAR(c.y0, f.moved_y0, 4);
    EXPECT_NEAR(c.y1, f.moved_y1, 4);
    const double background = fraction_labelled(r, f, 0, [&](int x, int y) {
      return x < f.moved_x0 - 8 || x >= f.moved_x1 + 8 || y < f.moved_y0 - 8 || y >= f.moved_y1 + 8;
    });
    EXPECT_GT(background, 0.99);
  }
}

TEST(MotionSegmentation, SecondModelWithGeometryOnlyOnItsBlock) {
  // Model 1 was tracked onto the moved block: it fits there (2 mm) and has no geometry elsewhere;
  // the background model misfits the block (5 cm).
  SyntheticSegmentationFrame f = make_synthetic_segmentation_frame(640, 480, 1);
  std::vector<float> object(f.costs[0].size(), kNaN);
  for (int y = f.moved_y0; y < f.moved_y1; ++y)
    for (int x = f.moved_x0; x < f.moved_x1; ++x) {
      const size_t i = static_cast<size_t>(y * f.width + x);
      if (f.depth_m[i] > 0) object[i] = 0.002f;
    }
  f.costs.push_back(object);
  MotionSegmenter seg{MotionSegmentationParams{}};
  const Superpixels sp = seg.superpixels(f.rgb.data(), f.depth_m.data(), f.width, f.height);
  const SegmentationResult r = seg.segment(sp, f.rgb.data(), f.depth_m.data(), spans(f.costs));
  EXPECT_TRUE(r.outlier_components.empty());
  EXPECT_GT(iou_with_block(r, 1, f), 0.9);
  const double background = fraction_labelled(r, f, 0, [&](int x, int y) {
    return x < f.moved_x0 - 8 || x >= f.moved_x1 + 8 || y < f.moved_y0 - 8 || y >= f.moved_y1 + 8;
  });
  EXPECT_GT(background, 0.99);
  ASSERT_EQ(r.model_pixels.size(), 2u);
  EXPECT_NEAR(r.model_pixels[1], 120 * 100, 120 * 100 / 10);
}

TEST(MotionSegmentation, IsDeterministicWhateverTheThreadCount) {
  const SyntheticSegmentationFrame f = make_synthetic_segmentation_frame(320, 240, 3, 5);
  auto run = [&] {
    MotionSegmenter seg{MotionSegmentationParams{}};
    const Superpixels sp = seg.superpixels(f.rgb.data(), f.depth_m.data(), f.width, f.height);
    return seg.segment(sp, f.rgb.data(), f.depth_m.data(), spans(f.costs)).labels;
  };
  const std::vector<uint8_t> a = run(), b = run();
  std::vector<uint8_t> c;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    c = run();
  }
  EXPECT_TRUE(a == b);
  EXPECT_TRUE(a == c);
}

// superpixels() prepares the CRF's nodes for its own superpixels; segment() reuses them only for
// those: other superpixels (made elsewhere, or by an earlier call) get theirs anew.
TEST(MotionSegmentation, NodesPreparedWithTheSuperpixelsAreUsedOnlyForThem) {
  const SyntheticSegmentationFrame a = make_synthetic_segmentation_frame(320, 240, 3, 5);
  const SyntheticSegmentationFrame b = make_synthetic_segmentation_frame(320, 240, 3, 9);
  const auto labels_from_scratch = [](const SyntheticSegmentationFrame& f, Superpixels sp) {
    sp.serial = 0;  // as if made elsewhere: the nodes are built inside segment()
    MotionSegmenter fresh{MotionSegmentationParams{}};
    return fresh.segment(sp, f.rgb.data(), f.depth_m.data(), spans(f.costs)).labels;
  };
  MotionSegmenter seg{MotionSegmentationParams{}};
  const Superpixels sp_a = seg.superpixels(a.rgb.data(), a.depth_m.data(), a.width, a.height);
  ASSERT_NE(sp_a.serial, 0u);
  const std::vector<uint8_t> prepared_a = seg.segment(sp_a, a.rgb.data(), a.depth_m.data(), spans(a.costs)).labels;
  EXPECT_TRUE(prepared_a == labels_from_scratch(a, sp_a));

  // b's superpixels are prepared now; a's (an earlier call) are built again, and b's after that.
  const Superpixels sp_b = seg.superpixels(b.rgb.data(), b.depth_m.data(), b.width, b.height);
  EXPECT_NE(sp_b.serial, sp_a.serial);
  const std::vector<uint8_t> again_a = seg.segment(sp_a, a.rgb.data(), a.depth_m.data(), spans(a.costs)).labels;
  EXPECT_TRUE(again_a == prepared_a);
  const std::vector<uint8_t> labels_b = seg.segment(sp_b, b.rgb.data(), b.depth_m.data(), spans(b.costs)).labels;
  EXPECT_TRUE(labels_b == labels_from_scratch(b, sp_b));
  EXPECT_FALSE(labels_b == prepared_a);
  // Superpixels made without their nodes get them in segment().
  const Superpixels bare_a = seg.superpixels(a.rgb.data(), a.depth_m.data(), a.width, a.height, false);
  EXPECT_TRUE(seg.segment(bare_a, a.rgb.data(), a.depth_m.data(), spans(a.costs)).labels == prepared_a);
}

TEST(MotionSegmentation, RejectsBadInput) {
  QuadFrame f;
  MotionSegmenter seg{MotionSegmentationParams{}};
  const std::vector<std::vector<float>> good = {std::vector<float>(1600, 0.002f)};
  std::vector<std::vector<float>> short_costs = {std::vector<float>(1600, 0.002f), std::vector<float>(1000, 0.0f)};
  EXPECT_NE(test::error_of([&] { seg.segment(f.sp, f.rgb.data(), f.depth_m.data(), spans(short_costs)); }).find("costs[1] has 1000 values, expected 1600"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { seg.segment(f.sp, nullptr, f.depth_m.data(), spans(good)); }).find("rgb"), std::string::npos);
  EXPECT_NE(test::error_of([&] { seg.segment(f.sp, f.rgb.data(), nullptr, spans(good)); }).find("depth"), std::string::npos);
  EXPECT_NE(test::error_of([&] { seg.superpixels(f.rgb.data(), f.depth_m.data(), 0, 10); }).find("0x10"), std::string::npos);
  Superpixels bad = f.sp;
  bad.label[77] = 9;
  EXPECT_NE(test::error_of([&] { seg.segment(bad, f.rgb.data(), f.depth_m.data(), spans(good)); }).find("label 9"), std::string::npos);
  bad = f.sp;
  bad.width = 20;
  EXPECT_NE(test::error_of([&] { seg.segment(bad, f.rgb.data(), f.depth_m.data(), spans(good)); }).find("20x40"), std::string::npos);
  std::vector<std::vector<float>> negative = good;
  negative[0][5] = -0.1f;
  EXPECT_NE(test::error_of([&] { seg.segment(f.sp, f.rgb.data(), f.depth_m.data(), spans(negative)); }).find("costs[0] at pixel (5, 0)"),
            std::string::npos);
  const std::vector<std::vector<float>> too_many(kMaxModels + 1, std::vector<float>(1600, 0.0f));
  EXPECT_NE(test::error_of([&] { seg.segment(f.sp, f.rgb.data(), f.depth_m.data(), spans(too_many)); }).find("at most 253"),
            std::string::npos);
  MotionSegmentationParams p;
  p.cost_scale_m = 0;
  EXPECT_NE(test::error_of([&] { MotionSegmenter s{p}; }).find("cost_scale_m"), std::string::npos);
}

}  // namespace
}  // namespace cofusion::segmentation
