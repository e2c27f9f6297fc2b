#include "segmentation/segmentation_bench.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <string>

#include "common/error.h"
#include "segmentation/motion_segmentation.h"

namespace cofusion::segmentation {

namespace {

// Small deterministic generator (xorshift32), so frames are identical on every platform.
struct Rng {
  uint32_t s;
  uint32_t next() {
    s ^= s << 13;
    s ^= s >> 17;
    s ^= s << 5;
    return s;
  }
  float uniform() { return static_cast<float>(next() >> 8) * (1.0f / 16777216.0f); }  // [0, 1)
};

struct Rect {
  int x0, y0, x1, y1;
  bool contains(int x, int y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
};

}  // namespace

SyntheticSegmentationFrame make_synthetic_segmentation_frame(int width, int height, int model_count, uint32_t seed) {
  if (width <= 0 || height <= 0 || model_count < 1)
    throw Error("synthetic segmentation frame: need a positive size and at least one model");
  SyntheticSegmentationFrame f;
  f.width = width;
  f.height = height;
  const auto n = static_cast<size_t>(width) * static_cast<size_t>(height);
  f.rgb.resize(n * 3);
  f.depth_m.resize(n);
  f.costs.assign(static_cast<size_t>(model_count), std::vector<float>(n));
  Rng rng{seed * 2654435761u + 1u};

  // The moved block (120x100 at 640x480, scaled) and one rectangle per object model.
  auto sx = [&](int v) { return v * width / 640; };
  auto sy = [&](int v) { return v * height / 480; };
  const Rect moved{sx(420), sy(300), sx(540), sy(400)};
  f.moved_x0 = moved.x0;
  f.moved_y0 = moved.y0;
  f.moved_x1 = moved.x1;
  f.moved_y1 = moved.y1;
  std::vector<Rect> objects;
  for (int m = 1; m < model_count; ++m) {
    const int k = m - 1;
    const int x0 = sx(40 + (k % 4) * 90), y0 = sy(40 + (k / 4 % 3) * 80);
    objects.push_back({x0, y0, x0 + sx(70), y0 + sy(60)});
  }

  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const size_t u = static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x);
      // Background: a sloped plane 1.5..3.5 m with colour patches (40x40 checks) and noise.
      float depth = 1.5f + 2.0f * static_cast<float>(y) / static_cast<float>(height);
      const int check = ((x / std::max(1, sx(40))) + (y / std::max(1, sy(40)))) % 3;
      float r = 90.0f + 50.0f * check, g = 120.0f - 30.0f * check, b = 60.0f + 40.0f * (2 - check);
      int object = -1;
      for (size_t o = 0; o < objects.size(); ++o)
        if (objects[o].contains(x, y)) object = static_cast<int>(o);
      const bool in_moved = moved.contains(x, y);
      if (object >= 0) {
        depth = 1.0f + 0.1f * static_cast<float>(object);
        r = 220.0f - 30.0f * static_cast<float>(object % 4);
        g = 40.0f + 40.0f * static_cast<float>(object % 3);
        b = 200.0f;
      } else if (in_moved) {
        depth = 1.2f;
        r = 30.0f;
        g = 200.0f;
        b = 230.0f;
      }
      const float noise = 12.0f * (rng.uniform() - 0.5f);
      f.rgb[3 * u] = static_cast<uint8_t>(std::clamp(r + noise, 0.0f, 255.0f));
      f.rgb[3 * u + 1] = static_cast<uint8_t>(std::clamp(g + noise, 0.0f, 255.0f));
      f.rgb[3 * u + 2] = static_cast<uint8_t>(std::clamp(b + noise, 0.0f, 255.0f));
      const bool hole = rng.uniform() < 0.01f;
      f.depth_m[u] = hole ? 0.0f : depth + 0.004f * (rng.uniform() - 0.5f);
      const float nan = std::numeric_limits<float>::quiet_NaN();
      const float small = 0.002f + 0.001f * (rng.uniform() - 0.5f);
      f.costs[0][u] = hole ? nan : (in_moved ? 0.05f + 0.01f * (rng.uniform() - 0.5f) : small);
      for (int m = 1; m < model_count; ++m)
        f.costs[static_cast<size_t>(m)][u] = !hole && object == m - 1 ? small : nan;
    }
  return f;
}

SegmentationBenchTimings bench_segmentation(const SegmentationBenchConfig& config) {
  if (config.repeats < 1) throw Error("bench_segmentation: repeats must be >= 1");
  const SyntheticSegmentationFrame f =
      make_synthetic_segmentation_frame(config.width, config.height, config.model_count);
  MotionSegmentationParams params;
  params.slic.superpixel_size_px = config.superpixel_size_px;
  params.crf.method = config.crf_method;
  MotionSegmenter segmenter(params);
  std::vector<std::span<const float>> costs;
  for (const auto& c : f.costs) costs.emplace_back(c);

  std::vector<double> slic, prepare, unary, crf, post, total;
  SegmentationBenchTimings t;
  for (int i = 0; i <= config.repeats; ++i) {
    const Superpixels sp = segmenter.superpixels(f.rgb.data(), f.depth_m.data(), f.width, f.height);
    const SegmentationResult r = segmenter.segment(sp, f.rgb.data(), f.depth_m.data(), costs);
    if (i == 0) {  // warm-up (allocations, TBB threads)
      t.superpixels = r.superpixel_count;
      t.crf_nodes = r.crf_node_count;
      continue;
    }
    slic.push_back(r.slic_ms);
    prepare.push_back(r.prepare_ms);
    unary.push_back(r.unary_ms);
    crf.push_back(r.crf_ms);
    post.push_back(r.post_ms);
    total.push_back(r.slic_ms + r.prepare_ms + r.unary_ms + r.crf_ms + r.post_ms);
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  t.slic_ms = median(slic);
  t.prepare_ms = median(prepare);
  t.unary_ms = median(unary);
  t.crf_ms = median(crf);
  t.post_ms = median(post);
  t.total_ms = median(total);
  return t;
}

}  // namespace cofusion::segmentation
