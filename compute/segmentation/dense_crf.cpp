#include "segmentation/dense_crf.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>

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

void DenseCrf::set_nodes(std::span<const CrfNode> nodes, const CrfParams& params) {
  check(params);
  params_ = params;
  node_count_ = static_cast<int>(nodes.size());
  const int n = node_count_;
  const auto un = static_cast<size_t>(n);
  for (size_t i = 0; i < un; ++i) {
    const CrfNode& c = nodes[i];
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.r) || !std::isfinite(c.g) ||
        !std::isfinite(c.b) || !std::isfinite(c.depth_m))
      throw Error("CRF: node " + std::to_string(i) + " has a non-finite feature");
  }

  if (params.method == CrfMethod::kPermutohedral) {
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
    appearance_.init(fa.data(), 6, n);
    smoothness_.init(fs.data(), 2, n);
    const std::vector<float> ones(un, 1.0f);
    norm_appearance_.resize(un);
    norm_smoothness_.resize(un);
    appearance_.filter(ones.data(), norm_appearance_.data(), 1);
    smoothness_.filter(ones.data(), norm_smoothness_.data(), 1);
    for (size_t i = 0; i < un; ++i) {
      norm_appearance_[i] = 1.0f / std::sqrt(norm_appearance_[i] + 1e-20f);
      norm_smoothness_[i] = 1.0f / std::sqrt(norm_smoothness_[i] + 1e-20f);
    }
    return;
  }

  // Exact: neighbours within the positional radius where the wider kernel falls to exact_cutoff,
  // found through square buckets of that size (3x3 buckets scanned per node).
  const float sigma_max = std::max(params.sigma_position, params.sigma_smoothness);
  const bool all_pairs = params.exact_cutoff <= 0;
  const float radius = all_pairs ? std::numeric_limits<float>::infinity()
                                 : sigma_max * std::sqrt(-2.0f * std::log(params.exact_cutoff));
  float x_min = 0, x_max = 0, y_min = 0, y_max = 0;
  for (size_t i = 0; i < un; ++i) {
    const float x = nodes[i].x, y = nodes[i].y;
    if (i == 0 || x < x_min) x_min = x;
    if (i == 0 || x > x_max) x_max = x;
    if (i == 0 || y < y_min) y_min = y;
    if (i == 0 || y > y_max) y_max = y;
  }
  // Buckets of half the radius (5x5 scanned), positions stored in bucket order for a tight scan.
  const float cell = all_pairs ? std::max({x_max - x_min, y_max - y_min, 1.0f}) + 1.0f : 0.5f * radius;
  const int reach = all_pairs ? 0 : 2;
  const int bw = std::max(1, static_cast<int>((x_max - x_min) / cell) + 1);
  const int bh = std::max(1, static_cast<int>((y_max - y_min) / cell) + 1);
  auto& bucket_of = bucket_of_;
  auto& bucket_begin = bucket_begin_;
  auto& bucket_nodes = bucket_nodes_;
  auto& bucket_x = bucket_x_;
  auto& bucket_y = bucket_y_;
  bucket_of.resize(un);
  bucket_begin.assign(static_cast<size_t>(bw) * static_cast<size_t>(bh) + 1, 0);
  bucket_nodes.resize(un);
  bucket_x.resize(un);
  bucket_y.resize(un);
  for (size_t i = 0; i < un; ++i) {
    const int bx = std::min(bw - 1, static_cast<int>((nodes[i].x - x_min) / cell));
    const int by = std::min(bh - 1, static_cast<int>((nodes[i].y - y_min) / cell));
    bucket_of[i] = by * bw + bx;
    ++bucket_begin[static_cast<size_t>(bucket_of[i]) + 1];
  }
  for (size_t b = 1; b < bucket_begin.size(); ++b) bucket_begin[b] += bucket_begin[b - 1];
  {
    auto& fill = bucket_fill_;
    fill.assign(bucket_begin.begin(), bucket_begin.end() - 1);
    for (size_t i = 0; i < un; ++i) {
      const auto k = static_cast<size_t>(fill[static_cast<size_t>(bucket_of[i])]++);
      bucket_nodes[k] = static_cast<int32_t>(i);
      bucket_x[k] = nodes[i].x;
      bucket_y[k] = nodes[i].y;
    }
  }
  const float r2 = radius * radius;
  // Calls fn(j, squared distance) for every neighbour j of i (i itself included), in a fixed order.
  auto for_neighbours = [&](size_t i, auto&& fn) {
    const int b = bucket_of[i];
    const int bx = b % bw, by = b / bw;
    const float xi = nodes[i].x, yi = nodes[i].y;
    for (int y = std::max(0, by - reach); y <= std::min(bh - 1, by + reach); ++y) {
      const int x0 = std::max(0, bx - reach), x1 = std::min(bw - 1, bx + reach);
      // Buckets x0..x1 of one bucket row are contiguous in bucket order.
      const int32_t k0 = bucket_begin[static_cast<size_t>(y * bw + x0)];
      const int32_t k1 = bucket_begin[static_cast<size_t>(y * bw + x1) + 1];
      for (int32_t k = k0; k < k1; ++k) {
        const float dx = bucket_x[static_cast<size_t>(k)] - xi, dy = bucket_y[static_cast<size_t>(k)] - yi;
        const float d2 = dx * dx + dy * dy;
        if (all_pairs || d2 <= r2) fn(bucket_nodes[static_cast<size_t>(k)], d2);
      }
    }
  };
  // Expected neighbours per node, to reserve the lists once.
  const double area = static_cast<double>(x_max - x_min + 1) * static_cast<double>(y_max - y_min + 1);
  const auto expected = static_cast<size_t>(
      std::min<double>(static_cast<double>(un), all_pairs ? static_cast<double>(un) : 3.2 * r2 * static_cast<double>(un) / area + 8));
  // Neighbour lists and kernel exponents in fixed node chunks (one scan), then concatenated.
  const float ia = -0.5f / (params.sigma_position * params.sigma_position);
  const float ic = -0.5f / (params.sigma_colour * params.sigma_colour);
  const float id = -0.5f / (params.sigma_depth_m * params.sigma_depth_m);
  const float is = -0.5f / (params.sigma_smoothness * params.sigma_smoothness);
  constexpr int kChunks = 16;
  auto& chunks = chunks_;
  chunks.resize(kChunks);
  row_begin_.assign(un + 1, 0);
  detail::for_fixed_chunks(n, kChunks, [&](int ch, int64_t i0, int64_t i1) {
    ExactChunk& c = chunks[static_cast<size_t>(ch)];
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
      for_neighbours(i, [&](int32_t j, float dp2) {
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
  auto& smooth = smooth_;
  auto& norm_a = norm_a_;
  auto& norm_s = norm_s_;
  smooth.resize(entries);
  norm_a.resize(un);
  norm_s.resize(un);
  detail::for_fixed_chunks(n, kChunks, [&](int ch, int64_t i0, int64_t) {
    const ExactChunk& c = chunks[static_cast<size_t>(ch)];
    const auto at = static_cast<size_t>(row_begin_[static_cast<size_t>(i0)]);
    std::copy(c.columns.begin(), c.columns.end(), columns_.begin() + static_cast<std::ptrdiff_t>(at));
    exp_nonpositive(c.arg_a.data(), values_.data() + at, c.arg_a.size());
    exp_nonpositive(c.arg_s.data(), smooth.data() + at, c.arg_s.size());
  });
  // Symmetric normalisation of each kernel, then the weighted sum.
  detail::for_range(n, 64, [&](int64_t i0, int64_t i1) {
    for (int64_t ii = i0; ii < i1; ++ii) {
      const auto i = static_cast<size_t>(ii);
      double sum_a = 0, sum_s = 0;
      for (auto e = static_cast<size_t>(row_begin_[i]); e < static_cast<size_t>(row_begin_[i + 1]); ++e) {
        sum_a += values_[e];
        sum_s += smooth[e];
      }
      norm_a[i] = static_cast<float>(1.0 / std::sqrt(sum_a));
      norm_s[i] = static_cast<float>(1.0 / std::sqrt(sum_s));
    }
  });
  const float wa = params.appearance_weight, ws = params.smoothness_weight;
  detail::for_range(n, 64, [&](int64_t i0, int64_t i1) {
    for (int64_t ii = i0; ii < i1; ++ii) {
      const auto i = static_cast<size_t>(ii);
      for (auto e = static_cast<size_t>(row_begin_[i]); e < static_cast<size_t>(row_begin_[i + 1]); ++e) {
        const auto j = static_cast<size_t>(columns_[e]);
        values_[e] = wa * values_[e] * norm_a[i] * norm_a[j] + ws * smooth[e] * norm_s[i] * norm_s[j];
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
    scaled_.resize(un * L);
    filtered_.resize(un * L);
    for (size_t i = 0; i < un; ++i)
      for (size_t l = 0; l < L; ++l) scaled_[i * L + l] = norm_appearance_[i] * q[i * L + l];
    appearance_.filter(scaled_.data(), filtered_.data(), label_count);
    for (size_t i = 0; i < un; ++i)
      for (size_t l = 0; l < L; ++l)
        out[i * L + l] = params_.appearance_weight * norm_appearance_[i] * filtered_[i * L + l];
    for (size_t i = 0; i < un; ++i)
      for (size_t l = 0; l < L; ++l) scaled_[i * L + l] = norm_smoothness_[i] * q[i * L + l];
    smoothness_.filter(scaled_.data(), filtered_.data(), label_count);
    for (size_t i = 0; i < un; ++i)
      for (size_t l = 0; l < L; ++l)
        out[i * L + l] += params_.smoothness_weight * norm_smoothness_[i] * filtered_[i * L + l];
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
