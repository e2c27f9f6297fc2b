// SLIC superpixels on synthetic images: edge adherence, count, connectivity, odd sizes,
// determinism, bad input.
#include <gtest/gtest.h>

#include <random>
#include <set>
#include <vector>

#include <tbb/global_control.h>

#include "segmentation/connected_components.h"
#include "segmentation/slic.h"
#include "support/test_support.h"

namespace cofusion::segmentation {
namespace {

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;
  std::vector<float> depth_m;
};

// Colour noise of +-amplitude around a base colour, constant depth.
Image noise_image(int w, int h, int amplitude, uint32_t seed) {
  Image im{w, h, std::vector<uint8_t>(static_cast<size_t>(w) * h * 3), std::vector<float>(static_cast<size_t>(w) * h, 2.0f)};
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> u(-amplitude, amplitude);
  for (size_t i = 0; i < im.rgb.size(); ++i) im.rgb[i] = static_cast<uint8_t>(128 + u(rng));
  return im;
}

// Every pixel labelled, labels in range, numbered in raster order of first pixel, and each
// superpixel one 4-connected component.
void expect_valid(const Superpixels& sp, int w, int h) {
  ASSERT_EQ(sp.width, w);
  ASSERT_EQ(sp.height, h);
  ASSERT_EQ(sp.label.size(), static_cast<size_t>(w) * h);
  ASSERT_GE(sp.count, 1);
  int32_t next = 0;
  for (const int32_t l : sp.label) {
    ASSERT_GE(l, 0);
    ASSERT_LT(l, sp.count);
    ASSERT_LE(l, next) << "labels must appear in raster order";
    if (l == next) ++next;
  }
  EXPECT_EQ(next, sp.count) << "every label 0..count-1 is used";
  ComponentLabelling cc;
  label_components<int32_t>(sp.label.data(), w, h, std::nullopt, cc);
  EXPECT_EQ(static_cast<int>(cc.components.size()), sp.count) << "each superpixel is one connected piece";
}

TEST(Slic, NoSuperpixelStraddlesAColourEdge) {
  // Two flat regions (with mild noise) split by a slanted edge that follows no grid line.
  const int w = 320, h = 240;
  Image im = noise_image(w, h, 4, 1);
  auto left = [](int x, int y) { return 3 * x + y < 500; };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (left(x, y)) {
        uint8_t* p = &im.rgb[(static_cast<size_t>(y) * w + x) * 3];
        p[0] = static_cast<uint8_t>(p[0] - 90);
        p[2] = static_cast<uint8_t>(p[2] + 90);
      }
  for (const bool coarse : {true, false}) {
    SlicParams params;
    params.coarse_to_fine = coarse;
    const Superpixels sp = compute_slic(im.rgb.data(), im.depth_m.data(), w, h, params);
    expect_valid(sp, w, h);
    std::vector<int> side(static_cast<size_t>(sp.count), -1);
    int straddling = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        int& s = side[static_cast<size_t>(sp.label[static_cast<size_t>(y) * w + x])];
        const int here = left(x, y) ? 0 : 1;
        if (s == -1) s = here;
        if (s != here) {
          ++straddling;
          s = 2;
        }
      }
    EXPECT_EQ(straddling, 0) << "coarse_to_fine = " << coarse;
  }
}

TEST(Slic, NoSuperpixelStraddlesADepthEdge) {
  // Same colour everywhere; a 1 m depth step that the depth term must follow.
  const int w = 320, h = 240;
  Image im = noise_image(w, h, 4, 2);
  auto near = [](int x, int y) { return (x - 150) * (x - 150) + (y - 110) * (y - 110) < 70 * 70; };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) im.depth_m[static_cast<size_t>(y) * w + x] = near(x, y) ? 1.0f : 2.0f;
  const Superpixels sp = compute_slic(im.rgb.data(), im.depth_m.data(), w, h, SlicParams{});
  expect_valid(sp, w, h);
  std::vector<std::set<bool>> sides(static_cast<size_t>(sp.count));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) sides[static_cast<size_t>(sp.label[static_cast<size_t>(y) * w + x])].insert(near(x, y));
  int straddling = 0;
  for (const auto& s : sides) straddling += s.size() > 1;
  EXPECT_EQ(straddling, 0);
}

TEST(Slic, CountIsCloseToTheGrid) {
  const int w = 640, h = 480;
  const Image im = noise_image(w, h, 10, 3);
  for (const int size : {16, 32}) {
    SlicParams params;
    params.superpixel_size_px = size;
    const Superpixels sp = compute_slic(im.rgb.data(), im.depth_m.data(), w, h, params);
    expect_valid(sp, w, h);
    const double nominal = static_cast<double>(w / size) * (h / size);
    EXPECT_GT(sp.count, 0.85 * nominal) << "S = " << size;
    EXPECT_LT(sp.count, 1.15 * nominal) << "S = " << size;
    EXPECT_NEAR(sp.step_x_px, size, 0.5);
    EXPECT_NEAR(sp.step_y_px, size, 0.5);
  }
}

TEST(Slic, HandlesOddAndTinySizes) {
  for (const auto& [w, h] : {std::pair{1, 1}, {2, 3}, {37, 23}, {640, 480}, {5, 200}}) {
    const Image im = noise_image(w, h, 60, static_cast<uint32_t>(w * 1000 + h));
    const Superpixels sp = compute_slic(im.rgb.data(), im.depth_m.data(), w, h, SlicParams{});
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    expect_valid(sp, w, h);
    if (w * h <= 6) {
      EXPECT_EQ(sp.count, 1);
    }
  }
}

TEST(Slic, ColourOnlyWithoutDepth) {
  const Image im = noise_image(64, 48, 30, 4);
  SlicParams params;
  params.depth_weight_per_m = 0;
  const Superpixels sp = compute_slic(im.rgb.data(), nullptr, 64, 48, params);
  expect_valid(sp, 64, 48);
}

TEST(Slic, IsDeterministicWhateverTheThreadCount) {
  const int w = 640, h = 480;
  Image im = noise_image(w, h, 40, 5);
  for (size_t i = 0; i < im.depth_m.size(); i += 7) im.depth_m[i] = 0;  // holes
  Slic slic;
  const Superpixels a = slic.compute(im.rgb.data(), im.depth_m.data(), w, h, SlicParams{});
  const Superpixels b = slic.compute(im.rgb.data(), im.depth_m.data(), w, h, SlicParams{});
  Superpixels c;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    c = compute_slic(im.rgb.data(), im.depth_m.data(), w, h, SlicParams{});
  }
  EXPECT_EQ(a.count, b.count);
  EXPECT_TRUE(a.label == b.label);
  EXPECT_EQ(a.count, c.count);
  EXPECT_TRUE(a.label == c.label);
}

TEST(Slic, RejectsBadInput) {
  const Image im = noise_image(8, 8, 10, 6);
  EXPECT_NE(test::error_of([&] { compute_slic(nullptr, im.depth_m.data(), 8, 8, {}); }).find("rgb"), std::string::npos);
  EXPECT_NE(test::error_of([&] { compute_slic(im.rgb.data(), nullptr, 8, 8, {}); }).find("depth"), std::string::npos);
  EXPECT_NE(test::error_of([&] { compute_slic(im.rgb.data(), im.depth_m.data(), 0, 8, {}); }).find("0x8"), std::string::npos);
  SlicParams bad;
  bad.superpixel_size_px = 0;
  EXPECT_NE(test::error_of([&] { compute_slic(im.rgb.data(), im.depth_m.data(), 8, 8, bad); }).find("superpixel_size_px"),
            std::string::npos);
  bad = {};
  bad.compactness = -1;
  EXPECT_NE(test::error_of([&] { compute_slic(im.rgb.data(), im.depth_m.data(), 8, 8, bad); }).find("compactness"),
            std::string::npos);
}

TEST(ConnectedComponents, LabelsRunsAndComponents) {
  // 0 0 1 1
  // 0 1 1 0
  // 2 2 0 0      (2 = ignored)
  const std::vector<uint8_t> img = {0, 0, 1, 1, 0, 1, 1, 0, 2, 2, 0, 0};
  ComponentLabelling cc;
  label_components<uint8_t>(img.data(), 4, 3, uint8_t{2}, cc);
  ASSERT_EQ(cc.components.size(), 3u);  // top-left 0s, the 1s, the right/bottom 0s
  EXPECT_EQ(cc.components[0].value, 0);
  EXPECT_EQ(cc.components[0].pixels, 3);
  EXPECT_EQ(cc.components[1].value, 1);
  EXPECT_EQ(cc.components[1].pixels, 4);
  EXPECT_EQ(cc.components[2].value, 0);
  EXPECT_EQ(cc.components[2].pixels, 3);
  EXPECT_EQ(cc.components[2].x0, 2);
  EXPECT_EQ(cc.components[2].y0, 1);
  EXPECT_EQ(cc.components[2].x1, 4);
  EXPECT_EQ(cc.components[2].y1, 3);
}

}  // namespace
}  // namespace cofusion::segmentation
