#include "segmentation/dense_crf.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>

#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include "common/error.h"
#include "segmentation/parallel.h"

namespace cofusion::segmentation {

namespace {

void check(const CrfParams& p) {
  auto positive = [](float v) { return v > 0 && std::isfinite(v); };
  auto non_negative = [](float v) { return v >= 0 && std::isfinite(v); };
  if (p.iterations < 0) throw Error("CRF: iterations must be >= 0, got " + std::to_string(p.iterations));
  if (!positive(p.sigma_colour) || !positive(p.sigma_depth_m) || !positive(p.sigma_position) ||
      !positive(p.sigma_smoothness))
    throw Error("CRF: every kernel sigma must be positive and finite");
  if (!non_negative(p.appearance_weight) || !non_negative(p.smoothness_weight))
    throw Error("CRF: kernel weights must be >= 0 and finite");
  if (!(p.exact_cutoff >= 0 && p.exact_cutoff < 1)) throw Error("CRF: exact_cutoff must be in [0, 1)");
}

// exp(x) for x <= 0 (clamped at -87), written so that GCC vectorises it (libm's expf is not):
// 2^n * p(r) with x = n ln2 + r, |r| <= ln2/2, p the degree-6 Taylor polynomial (relative error
// below 2e-7, so the kernel values match std::exp to float precision).
void exp_nonpositive(const float* __restrict x, float* __restrict y, size_t count) {
  for (size_t i = 0; i < count; ++i) {
    // Clamp with a bit mask: GCC does not vectorise a float select under -ftrapping-math.
    const int32_t low = -static_cast<int32_t>(x[i] < -87.0f);
    const float v = std::bit_cast<float>((std::bit_cast<int32_t>(x[i]) & ~low) | (std::bit_cast<int32_t>(-87.0f) & low));
    const int32_t k = static_cast<int32_t>(v * 1.44269504f - 0.5f);  // round to nearest for v <= 0
    const float kf = static_cast<float>(k);
    const float r = (v - kf * 0.693145752f) - kf * 1.42860677e-6f;  // ln2 split in two for accuracy
    float p = 1.0f / 720.0f;
    p = p * r + 1.0f / 120.0f;
    p = p * r + 1.0f / 24.0f;
    p = p * r + 1.0f / 6.0f;
    p = p * r + 0.5f;
    p = p * r + 1.0f;
    p = p * r + 1.0f;
    y[i] = p * std::bit_cast<float>((k + 127) << 23);
  }
}

// Row-wise softmax of -energy (numerically stable).
void softmax_rows(const float* energy, int nodes, int labels, float* q) {
  detail::for_range(nodes, 512, [&](int64_t i0, int64_t i1) {
    for (int64_t i = i0; i < i1; ++i) {
      const float* e = energy + i * labels;
      float* y = q + i * labels;
      float lo = e[0];
      for (int l = 1; l < labels; ++l) lo = std::min(lo, e[l]);
      float sum = 0;
      for (int l = 0; l < labels; ++l) {
        y[l] = std::exp(lo - e[l]);
        sum += y[l];
      }
      const float inv = 1.0f / sum;
      for (int l = 0; l < labels; ++l) y[l] *= inv;
    }
  });
}

}  // namespace

CrfMethod effective_method(CrfMethod method, int threads) {
  if (method != CrfMethod::kAuto) return method;
  return threads >= kExactMinThreads ? CrfMethod::kExact : CrfMethod::kPermutohedral;
}

void DenseCrf::set_nodes(std::span<const CrfNode> nodes, const CrfParams& params) {
  check(params);
  params_ = params;
  params_.method = effective_method(params.method, tbb::this_task_arena::max_concurrency());
  node_count_ = static_cast<int>(nodes.size());
  for (size_t i = 0; i < nodes.size(); ++i) {
    const CrfNode& c = nodes[i];
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.r) || !std::isfinite(c.g) ||
        !std::isfinite(c.b) || !std::isfinite(c.depth_m))
      throw Error("CRF: node " + std::to_string(i) + " has a non-finite feature");
  }
  if (params_.method == CrfMethod::kPermutohedral) {
    set_permutohedral(nodes);
    return;
  }
  const Buckets buckets = sort_into_buckets(nodes);
  build_exact_kernels(nodes, buckets);
  normalise_exact_kernels();
}

void DenseCrf::set_permutohedral(std::span<const CrfNode> nodes) {
  const auto un = nodes.size();
  const CrfParams& params = params_;
  std::vector<float> fa(un * 6), fs(un * 2);
  for (size_t i = 0; i < un; ++i) {
    const CrfNode& c = nodes[i];
    fa[i * 6 + 0] = c.x / params.sigma_position;
    fa[i * 6 + 1] = c.y / params.sigma_position;
    fa[i * 6 + 2] = c.r / params.sigma_colour;
    fa[i * 6 + 3] = c.g / params.sigma_colour;
    fa[i * 6 + 4] = c.b / params.sigma_colour;
    fa[i * 6 + 5] = c.depth_m / params.sigma_depth_m;
    fs[i * 2 + 0] = c.x / params.sigma_smoothness;
    fs[i * 2 + 1] = c.y / params.sigma_smoothness;
  }
  // Each kernel's lattice and normaliser, the two side by side.
  const std::vector<float> ones(un, 1.0f);
  const auto build = [&](PermutohedralLattice& lattice, const std::vector<float>& features, int d, std::vector<float>& norm) {
    lattice.init(features.data(), d, node_count_);
    norm.resize(un);
    lattice.filter(ones.data(), norm.data(), 1);
    for (float& v : norm) v = 1.0f / std::sqrt(v + 1e-20f);
  };
  tbb::parallel_invoke([&] { build(appearance_, fa, 6, norm_appearance_); },
                       [&] { build(smoothness_, fs, 2, norm_smoothness_); });
}

// Exact: neighbours within the positional radius where the wider kernel falls to exact_cutoff,
// found through square buckets of half that radius (5x5 scanned), the nodes' positions stored in
// bucket order for a tight scan.
DenseCrf::Buckets DenseCrf::sort_into_buckets(std::span<const CrfNode> nodes) {
  const auto un = nodes.size();
  Buckets g;
  const float sigma_max = std::max(params_.sigma_position, params_.sigma_smoothness);
  g.all_pairs = params_.exact_cutoff <= 0;
  const float radius = g.all_pairs ? std::numeric_limits<float>::infinity()
                                   : sigma_max * std::sqrt(-2.0f * std::log(params_.exact_cutoff));
  g.r2 = radius * radius;
  for (size_t i = 0; i < un; ++i) {
    const float x = nodes[i].x, y = nodes[i].y;
    if (i == 0 || x < g.x_min) g.x_min = x;
    if (i == 0 || x > g.x_max) g.x_max = x;
    if (i == 0 || y < g.y_min) g.y_min = y;
    if (i == 0 || y > g.y_max) g.y_max = y;
  }
  const float cell = g.all_pairs ? std::max({g.x_max - g.x_min, g.y_max - g.y_min, 1.0f}) + 1.0f : 0.5f * radius;
  g.reach = g.all_pairs ? 0 : 2;
  g.bw = std::max(1, static_cast<int>((g.x_max - g.x_min) / cell) + 1);
  g.bh = std::max(1, static_cast<int>((g.y_max - g.y_min) / cell) + 1);
  bucket_of_.resize(un);
  bucket_begin_.assign(static_cast<size_t>(g.bw) * static_cast<size_t>(g.bh) + 1, 0);
  bucket_nodes_.resize(un);
  bucket_x_.resize(un);
  bucket_y_.resize(un);
  for (size_t i = 0; i < un; ++i) {
    const int bx = std::min(g.bw - 1, static_cast<int>((nodes[i].x - g.x_min) / cell));
    const int by = std::min(g.bh - 1, static_cast<int>((nodes[i].y - g.y_min) / cell));
    bucket_of_[i] = by * g.bw + bx;
    ++bucket_begin_[static_cast<size_t>(bucket_of_[i]) + 1];
  }
  for (size_t b = 1; b < bucket_begin_.size(); ++b) bucket_begin_[b] += bucket_begin_[b - 1];
  bucket_fill_.assign(bucket_begin_.begin(), bucket_begin_.end() - 1);
  for (size_t i = 0; i < un; ++i) {
    const auto k = static_cast<size_t>(bucket_fill_[static_cast<size_t>(bucket_of_[i])]++);
    bucket_nodes_[k] = static_cast<int32_t>(i);
    bucket_x_[k] = nodes[i].x;
    bucket_y_[k] = nodes[i].y;
  }
  return g;
}

// Calls fn(j, squared distance) for every neighbour j of node i at (xi, yi), i itself included,
// in a fixed order.
template <typename Fn>
void DenseCrf::for_neighbours(const Buckets& g, size_t i, float xi, float yi, Fn&& fn) const {
  const int b = bucket_of_[i];
  const int bx = b % g.bw, by = b / g.bw;
  for (int y = std::max(0, by - g.reach); y <= std::min(g.bh - 1, by + g.reach); ++y) {
    const int x0 = std::max(0, bx - g.reach), x1 = std::min(g.bw - 1, bx + g.reach);
    // Buckets x0..x1 of one bucket row are contiguous in bucket order.
    const int32_t k0 = bucket_begin_[static_cast<size_t>(y * g.bw + x0)];
    const int32_t k1 = bucket_begin_[static_cast<size_t>(y * g.bw + x1) + 1];
    for (int32_t k = k0; k < k1; ++k) {
      const float dx = bucket_x_[static_cast<size_t>(k)] - xi, dy = bucket_y_[static_cast<size_t>(k)] - yi;
      const float d2 = dx * dx + dy * dy;
      if (g.all_pairs || d2 <= g.r2) fn(bucket_nodes_[static_cast<size_t>(k)], d2);
    }
  }
}

// Neighbour lists and both kernels' values (unnormalised) in CSR form: made in fixed node chunks
// (one scan), then concatenated.
void DenseCrf::build_exact_kernels(std::span<const CrfNode> nodes, const Buckets& g) {
  const int n = node_count_;
  const auto un = static_cast<size_t>(n);
  // Expected neighbours per node, to reserve the lists once.
  const double area = static_cast<double>(g.x_max - g.x_min + 1) * static_cast<double>(g.y_max - g.y_min + 1);
  const auto expected = static_cast<size_t>(std::min<double>(
      static_cast<double>(un), g.all_pairs ? static_cast<double>(un) : 3.2 * g.r2 * static_cast<double>(un) / area + 8));
  const float ia = -0.5f / (params_.sigma_position * params_.sigma_position);
  const float ic = -0.5f / (params_.sigma_colour * params_.sigma_colour);
  const float id = -0.5f / (params_.sigma_depth_m * params_.sigma_depth_m);
  const float is = -0.5f / (params_.sigma_smoothness * params_.sigma_smoothness);
  constexpr int kChunks = 16;
  chunks_.resize(kChunks);
  row_begin_.assign(un + 1, 0);
  detail::for_fixed_chunks(n, kChunks, [&](int ch, int64_t i0, int64_t i1) {
    ExactChunk& c = chunks_[static_cast<size_t>(ch)];
    c.columns.clear();
    c.arg_a.clear();
    c.arg_s.clear();
    const auto reserve = static_cast<size_t>(i1 - i0) * expected;
    c.columns.reserve(reserve);
    c.arg_a.reserve(reserve);
    c.arg_s.reserve(reserve);
    for (int64_t ii = i0; ii < i1; ++ii) {
      const auto i = static_cast<size_t>(ii);
      const CrfNode& a = nodes[i];
      const size_t before = c.columns.size();
      for_neighbours(g, i, a.x, a.y, [&](int32_t j, float dp2) {
        const CrfNode& b = nodes[static_cast<size_t>(j)];
        const float dr = a.r - b.r, dg = a.g - b.g, db = a.b - b.b, dd = a.depth_m - b.depth_m;
        c.columns.push_back(j);
        c.arg_a.push_back(ia * dp2 + ic * (dr * dr + dg * dg + db * db) + id * dd * dd);
        c.arg_s.push_back(is * dp2);
      });
      row_begin_[i + 1] = static_cast<int64_t>(c.columns.size() - before);
    }
  });
  for (size_t i = 0; i < un; ++i) row_begin_[i + 1] += row_begin_[i];
  const auto entries = static_cast<size_t>(row_begin_[un]);
  columns_.resize(entries);
  values_.resize(entries);
  smooth_.resize(entries);
  detail::for_fixed_chunks(n, kChunks, [&](int ch, int64_t i0, int64_t) {
    const ExactChunk& c = chunks_[static_cast<size_t>(ch)];
    const auto at = static_cast<size_t>(row_begin_[static_cast<size_t>(i0)]);
    std::copy(c.columns.begin(), c.columns.end(), columns_.begin() + static_cast<std::ptrdiff_t>(at));
    exp_nonpositive(c.arg_a.data(), values_.data() + at, c.arg_a.size());
    exp_nonpositive(c.arg_s.data(), smooth_.data() + at, c.arg_s.size());
  });
}

// Symmetric normalisation of each kernel, then their weighted sum into values_.
void DenseCrf::normalise_exact_kernels() {
  const int n = node_count_;
  norm_a_.resize(static_cast<size_t>(n));
  norm_s_.resize(static_cast<size_t>(n));
  detail::for_range(n, 64, [&](int64_t i0, int64_t i1) {
    for (int64_t ii = i0; ii < i1; ++ii) {
      const auto i = static_cast<size_t>(ii);
      double sum_a = 0, sum_s = 0;
      for (auto e = static_cast<size_t>(row_begin_[i]); e < static_cast<size_t>(row_begin_[i + 1]); ++e) {
        sum_a += values_[e];
        sum_s += smooth_[e];
      }
      norm_a_[i] = static_cast<float>(1.0 / std::sqrt(sum_a));
      norm_s_[i] = static_cast<float>(1.0 / std::sqrt(sum_s));
    }
  });
  const float wa = params_.appearance_weight, ws = params_.smoothness_weight;
  detail::for_range(n, 64, [&](int64_t i0, int64_t i1) {
    for (int64_t ii = i0; ii < i1; ++ii) {
      const auto i = static_cast<size_t>(ii);
      for (auto e = static_cast<size_t>(row_begin_[i]); e < static_cast<size_t>(row_begin_[i + 1]); ++e) {
        const auto j = static_cast<size_t>(columns_[e]);
        values_[e] = wa * values_[e] * norm_a_[i] * norm_a_[j] + ws * smooth_[e] * norm_s_[i] * norm_s_[j];
      }
    }
  });
}

void DenseCrf::message(std::span<const float> q, int label_count, std::span<float> out) const {
  const auto L = static_cast<size_t>(label_count);
  const auto un = static_cast<size_t>(node_count_);
  if (label_count < 1 || q.size() != un * L || out.size() != un * L)
    throw Error("CRF: message buffers must hold node_count x label_count values");
  if (params_.method == CrfMethod::kPermutohedral) {
    // The two kernels' filters run side by side, each on its own buffers.
    const auto filter = [&](const PermutohedralLattice& lattice, const std::vector<float>& norm, std::vector<float>& scaled,
                            std::vector<float>& filtered) {
      scaled.resize(un * L);
      filtered.resize(un * L);
      for (size_t i = 0; i < un; ++i)
        for (size_t l = 0; l < L; ++l) scaled[i * L + l] = norm[i] * q[i * L + l];
      lattice.filter(scaled.data(), filtered.data(), label_count);
    };
    tbb::parallel_invoke([&] { filter(appearance_, norm_appearance_, scaled_, filtered_); },
                         [&] { filter(smoothness_, norm_smoothness_, scaled_smoothness_, filtered_smoothness_); });
    for (size_t i = 0; i < un; ++i)
      for (size_t l = 0; l < L; ++l) {
        out[i * L + l] = params_.appearance_weight * norm_appearance_[i] * filtered_[i * L + l];
        out[i * L + l] += params_.smoothness_weight * norm_smoothness_[i] * filtered_smoothness_[i * L + l];
      }
    return;
  }
  // Exact: q copied with a row stride padded to a multiple of 4 so that one entry's update is one
  // or two vector multiply-adds.
  const size_t P = (L + 3) / 4 * 4;
  scaled_.assign(un * P, 0.0f);
  filtered_.resize(un * P);
  for (size_t i = 0; i < un; ++i) std::copy_n(q.data() + i * L, L, scaled_.data() + i * P);
  if (P == 4)
    exact_message<4>(scaled_.data(), filtered_.data(), 4);
  else if (P == 8)
    exact_message<8>(scaled_.data(), filtered_.data(), 8);
  else
    exact_message<0>(scaled_.data(), filtered_.data(), P);
  for (size_t i = 0; i < un; ++i) std::copy_n(filtered_.data() + i * P, L, out.data() + i * L);
}

template <int kStride>
void DenseCrf::exact_message(const float* q, float* out, size_t stride) const {
  const size_t P = kStride > 0 ? static_cast<size_t>(kStride) : stride;
  detail::for_range(node_count_, 64, [&](int64_t i0, int64_t i1) {
    std::vector<float> acc(P);
    for (int64_t ii = i0; ii < i1; ++ii) {
      const auto i = static_cast<size_t>(ii);
      std::fill(acc.begin(), acc.end(), 0.0f);
      float* a = acc.data();
      for (auto e = static_cast<size_t>(row_begin_[i]); e < static_cast<size_t>(row_begin_[i + 1]); ++e) {
        const float k = values_[e];
        const float* qj = q + static_cast<size_t>(columns_[e]) * P;
        for (size_t l = 0; l < P; ++l) a[l] += k * qj[l];
      }
      std::copy_n(a, P, out + i * P);
    }
  });
}

void DenseCrf::infer(std::span<const float> unary, int label_count, std::vector<float>& q) const {
  const auto L = static_cast<size_t>(label_count);
  const auto un = static_cast<size_t>(node_count_);
  if (label_count < 1 || unary.size() != un * L)
    throw Error("CRF: unary energies must hold node_count x label_count values (" + std::to_string(un) + " x " +
                std::to_string(L) + "), got " + std::to_string(unary.size()));
  q.resize(un * L);
  if (un == 0) return;
  softmax_rows(unary.data(), node_count_, label_count, q.data());
  message_.resize(un * L);
  for (int it = 0; it < params_.iterations; ++it) {
    message(q, label_count, message_);
    // Potts: energy of label l drops by the kernel-weighted mass of neighbours already taking l.
    for (size_t k = 0; k < un * L; ++k) message_[k] = unary[k] - message_[k];
    softmax_rows(message_.data(), node_count_, label_count, q.data());
  }
}

}  // namespace cofusion::segmentation
