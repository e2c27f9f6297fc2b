#include "segmentation/motion_segmentation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "common/error.h"
#include "segmentation/parallel.h"

namespace cofusion::segmentation {

namespace {

// Fixed row chunks for the per-superpixel sums (deterministic whatever the thread count).
constexpr int kChunks = 8;
// Per superpixel sums: pixels, x, y, r, g, b, pixels with depth, depth; then per model: pixels
// with depth and a cost, cost sum.
constexpr int kBaseSums = 8;

bool valid_depth(float d) { return std::isfinite(d) && d > 0; }

std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }


// Throws a message naming the first inconsistency between the superpixels, images and costs.
void check_unary_inputs(const Superpixels& sp, const uint8_t* rgb, const float* depth_m,
                        std::span<const std::span<const float>> costs, int max_models) {
  const int w = sp.width, h = sp.height;
  if (w <= 0 || h <= 0) throw Error("motion segmentation: superpixel image size must be positive, got " + size_text(w, h));
  const auto n = static_cast<size_t>(w) * static_cast<size_t>(h);
  if (sp.label.size() != n || sp.count <= 0)
    throw Error("motion segmentation: superpixels hold " + std::to_string(sp.label.size()) + " labels and " +
                std::to_string(sp.count) + " superpixels for a " + size_text(w, h) + " image");
  if (rgb == nullptr) throw Error("motion segmentation: rgb image pointer is null");
  if (depth_m == nullptr) throw Error("motion segmentation: depth image pointer is null");
  if (costs.size() > static_cast<size_t>(max_models))
    throw Error("motion segmentation: " + std::to_string(costs.size()) + " models, at most " +
                std::to_string(max_models) + " are supported");
  for (size_t m = 0; m < costs.size(); ++m)
    if (costs[m].size() != n)
      throw Error("motion segmentation: costs[" + std::to_string(m) + "] has " + std::to_string(costs[m].size()) +
                  " values, expected " + std::to_string(n) + " (" + size_text(w, h) + ")");
}

// What one row chunk saw besides its sums: the depth range and the first bad label or cost.
struct ChunkInfo {
  float depth_min = std::numeric_limits<float>::infinity();
  float depth_max = -std::numeric_limits<float>::infinity();
  int64_t bad_label = -1, bad_cost = -1;  // first offending pixel
  int bad_cost_model = 0;
};

bool bad_cost_value(float v) { return !(v >= 0 && v <= std::numeric_limits<float>::max()); }

// Per superpixel sums over the pixels of a chunk of rows: with `base`, the kBaseSums (layout
// above); else per model the pixels with depth and a cost and their cost sum. One run of a
// superpixel within a row is summed locally, then added once.
class ChunkSums {
 public:
  ChunkSums(const Superpixels& sp, const uint8_t* rgb, const float* depth_m, std::span<const std::span<const float>> costs,
            bool base)
      : sp_(sp), rgb_(rgb), depth_m_(depth_m), costs_(costs), base_(base),
        stride_(base ? size_t{kBaseSums} : 2 * costs.size()), run_(stride_), row_depth_(static_cast<size_t>(sp.width)),
        row_valid_(static_cast<size_t>(sp.width)) {}

  ChunkInfo add_rows(double* acc, int64_t y0, int64_t y1) {
    const int w = sp_.width;
    for (int64_t y = y0; y < y1; ++y) {
      const auto row = static_cast<size_t>(y) * static_cast<size_t>(w);
      load_depth_row(row);
      int x = 0;
      while (x < w) {
        const int32_t k = sp_.label[row + static_cast<size_t>(x)];
        if (k < 0 || k >= sp_.count) {
          if (info_.bad_label < 0) info_.bad_label = static_cast<int64_t>(row) + x;
          ++x;
          continue;
        }
        const int xs = x;
        while (x < w && sp_.label[row + static_cast<size_t>(x)] == k) ++x;
        if (base_)
          sum_run(row, static_cast<int>(y), xs, x);
        else
          for (size_t m = 0; m < costs_.size(); ++m) sum_costs(m, row, xs, x);
        double* acc_k = acc + static_cast<size_t>(k) * stride_;
        for (size_t j = 0; j < stride_; ++j) acc_k[j] += run_[j];
      }
    }
    return info_;
  }

 private:
  void load_depth_row(size_t row) {
    for (int x = 0; x < sp_.width; ++x) {
      const float d = depth_m_[row + static_cast<size_t>(x)];
      const bool ok = valid_depth(d);
      row_valid_[static_cast<size_t>(x)] = ok;
      if (!base_) continue;  // the cost sums need only which pixels have depth
      row_depth_[static_cast<size_t>(x)] = ok ? d : 0.0f;
      if (ok) {
        info_.depth_min = std::min(info_.depth_min, d);
        info_.depth_max = std::max(info_.depth_max, d);
      }
    }
  }

  // Pixels [xs, xe) of row y into run_ (integers, floats as the layout says).
  void sum_run(size_t row, int y, int xs, int xe) {
    uint32_t sr = 0, sg = 0, sb = 0, nd = 0;
    float sd = 0;
    for (int i = xs; i < xe; ++i) {
      const size_t u = row + static_cast<size_t>(i);
      sr += rgb_[3 * u];
      sg += rgb_[3 * u + 1];
      sb += rgb_[3 * u + 2];
      nd += row_valid_[static_cast<size_t>(i)];
      sd += row_depth_[static_cast<size_t>(i)];
    }
    const double len = xe - xs;
    run_[0] = len;
    run_[1] = len * (xs + xe - 1) * 0.5;
    run_[2] = len * static_cast<double>(y);
    run_[3] = sr;
    run_[4] = sg;
    run_[5] = sb;
    run_[6] = nd;
    run_[7] = sd;
  }

  // Costs count where the pixel has depth; NaN = no geometry.
  void sum_costs(size_t m, size_t row, int xs, int xe) {
    const float* c = costs_[m].data() + row;
    uint32_t n_cost = 0;
    float s_cost = 0;
    bool bad = false;
    for (int i = xs; i < xe; ++i) {
      const float v = c[i];
      const bool use = row_valid_[static_cast<size_t>(i)] && !std::isnan(v);
      bad |= use && bad_cost_value(v);
      n_cost += use;
      s_cost += use ? v : 0.0f;
    }
    if (bad && info_.bad_cost < 0)
      for (int i = xs; i < xe && info_.bad_cost < 0; ++i)
        if (row_valid_[static_cast<size_t>(i)] && !std::isnan(c[i]) && bad_cost_value(c[i])) {
          info_.bad_cost = static_cast<int64_t>(row) + i;
          info_.bad_cost_model = static_cast<int>(m);
        }
    run_[2 * m] = n_cost;
    run_[2 * m + 1] = s_cost;
  }

  const Superpixels& sp_;
  const uint8_t* rgb_;
  const float* depth_m_;
  std::span<const std::span<const float>> costs_;
  const bool base_;
  const size_t stride_;
  std::vector<double> run_;
  std::vector<float> row_depth_;  // valid depth or 0
  std::vector<uint8_t> row_valid_;
  ChunkInfo info_;  // per chunk: neighbouring chunks' entries would share a cache line
};

// Throws for the first bad label or cost any chunk met; else returns the frame's depth range
// (max - min over valid readings, 0 without any).
float checked_depth_range_m(const std::vector<ChunkInfo>& info, const Superpixels& sp,
                            std::span<const std::span<const float>> costs) {
  const int w = sp.width;
  float depth_min = std::numeric_limits<float>::infinity(), depth_max = -std::numeric_limits<float>::infinity();
  for (const ChunkInfo& ci : info) {
    if (ci.bad_label >= 0)
      throw Error("motion segmentation: superpixel label " + std::to_string(sp.label[static_cast<size_t>(ci.bad_label)]) +
                  " at pixel (" + std::to_string(ci.bad_label % w) + ", " + std::to_string(ci.bad_label / w) +
                  ") is outside 0.." + std::to_string(sp.count - 1));
    if (ci.bad_cost >= 0)
      throw Error("motion segmentation: costs[" + std::to_string(ci.bad_cost_model) + "] at pixel (" +
                  std::to_string(ci.bad_cost % w) + ", " + std::to_string(ci.bad_cost / w) + ") is " +
                  std::to_string(costs[static_cast<size_t>(ci.bad_cost_model)][static_cast<size_t>(ci.bad_cost)]) +
                  " (expected metres >= 0, or NaN for no geometry)");
    depth_min = std::min(depth_min, ci.depth_min);
    depth_max = std::max(depth_max, ci.depth_max);
  }
  return depth_max >= depth_min ? depth_max - depth_min : 0.0f;
}

// The chunks' sums added in chunk order (deterministic), per superpixel.
std::vector<double> combine_chunks(const std::vector<double>& partial, int K, size_t stride) {
  std::vector<double> sums(static_cast<size_t>(K) * stride, 0.0);
  detail::for_range(K, 128, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int ch = 0; ch < kChunks; ++ch) {
        const double* a = partial.data() + (static_cast<size_t>(ch) * static_cast<size_t>(K) + static_cast<size_t>(k)) * stride;
        double* s = sums.data() + static_cast<size_t>(k) * stride;
        for (size_t j = 0; j < stride; ++j) s[j] += a[j];
      }
  });
  return sums;
}

// Cost of a model without geometry at a superpixel (metres): the paper's fixed cost, a share of
// the frame's depth range, bounded below and above (objects by their own maximum).
struct NoGeometryCosts {
  float background_m = 0, object_m = 0;
  NoGeometryCosts(const MotionSegmentationParams& p, float depth_range_m) {
    const float unbounded_m = std::max(p.no_geometry_cost_fraction * depth_range_m, p.no_geometry_cost_min_m);
    background_m = std::min(unbounded_m, p.no_geometry_cost_max_m);
    object_m = std::min(unbounded_m, p.object_no_geometry_cost_max_m);
  }
};

}  // namespace

MotionSegmenter::MotionSegmenter(MotionSegmentationParams params) : params_(std::move(params)) {
  const auto& p = params_;
  auto positive = [](float v) { return v > 0 && std::isfinite(v); };
  auto non_negative = [](float v) { return v >= 0 && std::isfinite(v); };
  if (!positive(p.cost_scale_m)) throw Error("motion segmentation: cost_scale_m must be positive");
  if (!(p.min_geometry_fraction >= 0 && p.min_geometry_fraction <= 1))
    throw Error("motion segmentation: min_geometry_fraction must be in [0, 1]");
  if (!non_negative(p.no_geometry_cost_fraction) || !non_negative(p.no_geometry_cost_min_m) ||
      !non_negative(p.no_geometry_cost_max_m) || p.no_geometry_cost_max_m < p.no_geometry_cost_min_m ||
      !non_negative(p.object_no_geometry_cost_max_m) || p.object_no_geometry_cost_max_m < p.no_geometry_cost_min_m)
    throw Error("motion segmentation: no-geometry costs must be >= 0 and finite, with min <= max");
  if (!std::isfinite(p.outlier_threshold) || !non_negative(p.outlier_slope) || !non_negative(p.outlier_min_energy))
    throw Error("motion segmentation: outlier energy parameters must be finite (slope and minimum >= 0)");
  if (p.min_component_px < 0) throw Error("motion segmentation: min_component_px must be >= 0");
  if (p.min_object_component_px < 0) throw Error("motion segmentation: min_object_component_px must be >= 0");
  // Parameter checks of SLIC and the CRF happen on first use; run the CRF's now on an empty set.
  DenseCrf probe;
  probe.set_nodes({}, p.crf);
}

Superpixels MotionSegmenter::superpixels(const uint8_t* rgb, const float* depth_m, int width, int height,
                                         bool prepare) {
  if (depth_m == nullptr) throw Error("motion segmentation: depth image pointer is null");
  const auto t0 = std::chrono::steady_clock::now();
  Superpixels sp = slic_.compute(rgb, depth_m, width, height, params_.slic);
  last_slic_ms_ = detail::ms_since(t0);
  sp.serial = ++last_serial_;
  if (!prepare) return sp;
  const auto t1 = std::chrono::steady_clock::now();
  prepare_nodes(sp, rgb, depth_m);
  last_prepare_ms_ = detail::ms_since(t1);
  return sp;
}


// The base sums (`base`) or the costs' sums per superpixel over every pixel, added in fixed row
// chunks in chunk order (deterministic); throws for a bad label or cost. With the base sums,
// *depth_range_m gets the frame's depth range.
std::vector<double> MotionSegmenter::chunk_sums(const Superpixels& sp, const uint8_t* rgb, const float* depth_m,
                                                std::span<const std::span<const float>> costs, bool base,
                                                float* depth_range_m) {
  const int K = sp.count;
  const size_t stride = base ? size_t{kBaseSums} : 2 * costs.size();
  partial_.assign(static_cast<size_t>(kChunks) * static_cast<size_t>(K) * stride, 0.0);
  std::vector<ChunkInfo> info(kChunks);
  detail::for_fixed_chunks(sp.height, kChunks, [&](int chunk, int64_t y0, int64_t y1) {
    double* acc = partial_.data() + static_cast<size_t>(chunk) * static_cast<size_t>(K) * stride;
    info[static_cast<size_t>(chunk)] = ChunkSums(sp, rgb, depth_m, costs, base).add_rows(acc, y0, y1);
  });
  const float range_m = checked_depth_range_m(info, sp, costs);
  if (depth_range_m) *depth_range_m = range_m;
  return combine_chunks(partial_, K, stride);
}

const MotionSegmenter::Unaries& MotionSegmenter::compute_unaries(const Superpixels& sp, const uint8_t* rgb,
                                                                 const float* depth_m,
                                                                 std::span<const std::span<const float>> costs) {
  check_unary_inputs(sp, rgb, depth_m, costs, kMaxModels);
  if (sp.serial == 0 || sp.serial != prepared_serial_) prepare_nodes(sp, rgb, depth_m);
  const std::vector<double> cost_sums =
      costs.empty() ? std::vector<double>() : chunk_sums(sp, rgb, depth_m, costs, false, nullptr);
  make_energies(cost_sums, static_cast<int>(costs.size()));
  return unaries_;
}

// Each CRF node's position (in grid steps), colour and depth from the per-superpixel sums, and
// the CRF's kernels over them.
void MotionSegmenter::prepare_nodes(const Superpixels& sp, const uint8_t* rgb, const float* depth_m) {
  check_unary_inputs(sp, rgb, depth_m, {}, kMaxModels);
  Unaries& u = unaries_;
  base_sums_ = chunk_sums(sp, rgb, depth_m, {}, true, &u.depth_range_m);
  const int K = sp.count;
  // Superpixels with depth become CRF nodes.
  u.crf_node_of.assign(static_cast<size_t>(K), -1);
  u.crf_superpixel.clear();
  for (int32_t k = 0; k < K; ++k)
    if (base_sums_[static_cast<size_t>(k) * kBaseSums + 6] > 0) {
      u.crf_node_of[static_cast<size_t>(k)] = static_cast<int32_t>(u.crf_superpixel.size());
      u.crf_superpixel.push_back(k);
    }
  const float step_x = sp.step_x_px > 0 ? sp.step_x_px : static_cast<float>(params_.slic.superpixel_size_px);
  const float step_y = sp.step_y_px > 0 ? sp.step_y_px : static_cast<float>(params_.slic.superpixel_size_px);
  u.nodes.resize(u.crf_superpixel.size());
  detail::for_range(static_cast<int64_t>(u.nodes.size()), 256, [&](int64_t i0, int64_t i1) {
    for (int64_t ii = i0; ii < i1; ++ii) {
      const auto i = static_cast<size_t>(ii);
      const double* s = base_sums_.data() + static_cast<size_t>(u.crf_superpixel[i]) * kBaseSums;
      CrfNode& node = u.nodes[i];
      node.x = static_cast<float>(s[1] / s[0]) / step_x;
      node.y = static_cast<float>(s[2] / s[0]) / step_y;
      node.r = static_cast<float>(s[3] / s[0]);
      node.g = static_cast<float>(s[4] / s[0]);
      node.b = static_cast<float>(s[5] / s[0]);
      node.depth_m = static_cast<float>(s[7] / s[6]);
    }
  });
  crf_.set_nodes(u.nodes, params_.crf);
  prepared_serial_ = sp.serial;
}

// Each node's label energies: the mean cost of every model with geometry there (else its fixed
// cost), and the outlier label's energy, which falls as the best model's rises.
void MotionSegmenter::make_energies(const std::vector<double>& cost_sums, int M) {
  Unaries& u = unaries_;
  const auto& p = params_;
  const NoGeometryCosts fixed(p, u.depth_range_m);
  const size_t L = static_cast<size_t>(M) + 1;
  const size_t nodes = u.crf_superpixel.size();
  u.energy.resize(nodes * L);
  detail::for_range(static_cast<int64_t>(nodes), 256, [&](int64_t i0, int64_t i1) {
    for (int64_t ii = i0; ii < i1; ++ii) {
      const auto i = static_cast<size_t>(ii);
      const auto k = static_cast<size_t>(u.crf_superpixel[i]);
      const double with_depth = base_sums_[k * kBaseSums + 6];
      const double* c = cost_sums.data() + k * 2 * static_cast<size_t>(M);
      float* e = u.energy.data() + i * L;
      bool any_geometry = false;
      float best = std::numeric_limits<float>::infinity();
      for (int m = 0; m < M; ++m) {
        const double with_cost = c[2 * static_cast<size_t>(m)];
        const bool has_geometry = with_cost > 0 && with_cost >= p.min_geometry_fraction * with_depth;
        const float cost_m = has_geometry ? static_cast<float>(c[2 * static_cast<size_t>(m) + 1] / with_cost)
                                          : (m == 0 ? fixed.background_m : fixed.object_m);
        e[m] = cost_m / p.cost_scale_m;
        if (has_geometry) {
          any_geometry = true;
          best = std::min(best, e[m]);
        }
      }
      e[M] = std::max(p.outlier_threshold - p.outlier_slope * (any_geometry ? best : 0.0f), p.outlier_min_energy);
    }
  });
}

SegmentationResult MotionSegmenter::segment(const Superpixels& sp, const uint8_t* rgb, const float* depth_m,
                                            std::span<const std::span<const float>> costs) {
  SegmentationResult result;
  result.slic_ms = last_slic_ms_;
  result.prepare_ms = sp.serial != 0 && sp.serial == prepared_serial_ ? last_prepare_ms_ : 0.0;
  auto t = std::chrono::steady_clock::now();
  const Unaries& u = compute_unaries(sp, rgb, depth_m, costs);
  result.unary_ms = detail::ms_since(t);

  t = std::chrono::steady_clock::now();
  const int M = static_cast<int>(costs.size());
  const int L = M + 1;
  crf_.infer(u.energy, L, q_);
  const size_t nodes = u.nodes.size();
  node_label_.resize(nodes);
  for (size_t i = 0; i < nodes; ++i) {
    const float* qi = q_.data() + i * static_cast<size_t>(L);
    node_label_[i] = static_cast<uint8_t>(std::max_element(qi, qi + L) - qi);  // ties: lowest index
  }
  const int w = sp.width, h = sp.height;
  const auto n = static_cast<int64_t>(w) * h;
  result.width = w;
  result.height = h;
  result.model_count = M;
  result.superpixel_count = sp.count;
  result.crf_node_count = static_cast<int>(nodes);
  result.depth_range_m = u.depth_range_m;
  result.labels.resize(static_cast<size_t>(n));
  detail::for_range(n, 16384, [&](int64_t i0, int64_t i1) {
    for (int64_t i = i0; i < i1; ++i) {
      const auto px = static_cast<size_t>(i);
      const int32_t node = u.crf_node_of[static_cast<size_t>(sp.label[px])];
      result.labels[px] = node >= 0 && valid_depth(depth_m[px]) ? node_label_[static_cast<size_t>(node)] : kNoLabel;
    }
  });
  result.crf_ms = detail::ms_since(t);

  t = std::chrono::steady_clock::now();
  postprocess(result.labels, w, h, M, result);
  result.post_ms = detail::ms_since(t);
  return result;
}

void MotionSegmenter::postprocess(std::vector<uint8_t>& labels, int width, int height, int model_count,
                                  SegmentationResult& result) {
  if (width <= 0 || height <= 0) throw Error("motion segmentation: label image size must be positive, got " + size_text(width, height));
  if (labels.size() != static_cast<size_t>(width) * static_cast<size_t>(height))
    throw Error("motion segmentation: " + std::to_string(labels.size()) + " labels for a " + size_text(width, height) + " image");
  if (model_count < 0 || model_count > kMaxModels)
    throw Error("motion segmentation: model_count " + std::to_string(model_count) + " outside 0.." + std::to_string(kMaxModels));
  label_components<uint8_t>(labels.data(), width, height, kNoLabel, components_);
  auto& comps = components_.components;
  const int outlier = model_count;
  for (const ComponentInfo& c : comps)
    if (c.value > outlier)
      throw Error("motion segmentation: label " + std::to_string(c.value) + " at (" + std::to_string(c.x0) + ", " +
                  std::to_string(c.y0) + ") is neither a model (0.." + std::to_string(model_count - 1) +
                  "), the outlier label nor kNoLabel");

  // An object (label 1..model_count-1) is one rigid body: keep its largest component only (first
  // in raster order on ties). The background (0) may be split by objects in front of it, and every
  // outlier component is a candidate new object.
  std::vector<int32_t> largest(static_cast<size_t>(model_count) + 1, -1);
  for (int32_t i = 0; i < static_cast<int32_t>(comps.size()); ++i) {
    int32_t& best = largest[static_cast<size_t>(comps[static_cast<size_t>(i)].value)];
    if (best < 0 || comps[static_cast<size_t>(i)].pixels > comps[static_cast<size_t>(best)].pixels) best = i;
  }
  std::vector<uint8_t> keep(comps.size(), 1);
  for (size_t i = 0; i < comps.size(); ++i) {
    const int v = comps[i].value;
    const bool object = v != 0 && v != outlier;
    if (comps[i].pixels < (object ? params_.min_object_component_px : params_.min_component_px)) keep[i] = 0;
    if (object && largest[static_cast<size_t>(v)] != static_cast<int32_t>(i)) keep[i] = 0;
  }
  detail::for_range(static_cast<int64_t>(components_.runs.size()), 1024, [&](int64_t a, int64_t e) {
    for (int64_t i = a; i < e; ++i) {
      const LabelRun& run = components_.runs[static_cast<size_t>(i)];
      if (!keep[static_cast<size_t>(run.component)])
        std::fill_n(labels.begin() + static_cast<std::ptrdiff_t>(run.y) * width + run.x0, run.x1 - run.x0, kNoLabel);
    }
  });

  result.model_pixels.assign(static_cast<size_t>(model_count), 0);
  result.outlier_components.clear();
  for (size_t i = 0; i < comps.size(); ++i) {
    if (!keep[i]) continue;
    const ComponentInfo& c = comps[i];
    if (c.value == outlier)
      result.outlier_components.push_back(
          {static_cast<uint8_t>(c.value), static_cast<int>(c.pixels), c.x0, c.y0, c.x1, c.y1});
    else
      result.model_pixels[static_cast<size_t>(c.value)] += static_cast<int>(c.pixels);
  }
  std::stable_sort(result.outlier_components.begin(), result.outlier_components.end(),
                   [](const SegmentationResult::Component& a, const SegmentationResult::Component& b) {
                     return a.pixels > b.pixels;
                   });
}

}  // namespace cofusion::segmentation
