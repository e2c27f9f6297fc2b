#include "segmentation/permutohedral.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <tbb/task_arena.h>

#include "common/error.h"
#include "segmentation/parallel.h"

namespace cofusion::segmentation {

namespace {

// Open-addressing hash from a lattice key (d ints: the first d coordinates of a remainder-0
// point in the (d+1)-dimensional embedding; the last is minus their sum) to a vertex index.
class KeyTable {
 public:
  KeyTable(int d, size_t expected) : d_(d) {
    size_t cap = 64;
    while (cap < 2 * expected) cap *= 2;
    mask_ = cap - 1;
    slots_.assign(cap, -1);
    keys_.reserve(expected * static_cast<size_t>(d));
  }
  bool same(const int32_t* a, const int32_t* b) const {
    for (int i = 0; i < d_; ++i)
      if (a[i] != b[i]) return false;
    return true;
  }
  int32_t find(const int32_t* key) const {
    for (size_t h = hash(key) & mask_;; h = (h + 1) & mask_) {
      const int32_t s = slots_[h];
      if (s < 0) return -1;
      if (same(key, keys_.data() + static_cast<size_t>(s) * d_)) return s;
    }
  }
  int32_t insert(const int32_t* key) {
    if (2 * (static_cast<size_t>(size()) + 1) > slots_.size()) grow();
    for (size_t h = hash(key) & mask_;; h = (h + 1) & mask_) {
      const int32_t s = slots_[h];
      if (s < 0) {
        slots_[h] = size();
        keys_.insert(keys_.end(), key, key + d_);
        return slots_[h];
      }
      if (same(key, keys_.data() + static_cast<size_t>(s) * d_)) return s;
    }
  }
  int32_t size() const { return static_cast<int32_t>(keys_.size() / static_cast<size_t>(d_)); }
  const int32_t* key(int32_t i) const { return keys_.data() + static_cast<size_t>(i) * d_; }

 private:
  size_t hash(const int32_t* key) const {
    size_t h = 0;
    for (int i = 0; i < d_; ++i) h = (h + static_cast<size_t>(static_cast<uint32_t>(key[i]))) * 2531011u;
    return h ^ (h >> 17);
  }
  void grow() {
    mask_ = mask_ * 2 + 1;
    slots_.assign(mask_ + 1, -1);
    for (int32_t s = 0; s < size(); ++s)
      for (size_t h = hash(key(s)) & mask_;; h = (h + 1) & mask_)
        if (slots_[h] < 0) {
          slots_[h] = s;
          break;
        }
  }
  int d_;
  size_t mask_ = 0;
  std::vector<int32_t> slots_;
  std::vector<int32_t> keys_;
};

// Elevation of a feature vector into the hyperplane sum = 0 of R^(d+1), scaled so that the
// lattice blur matches a unit-sigma Gaussian (Adams et al. 2010, section 3; the factor as in
// Krähenbühl's code): `scale` from elevation_scale(), `elevated` of d + 1 values.
std::vector<float> elevation_scale(int d) {
  const float inv_std = std::sqrt(2.0f / 3.0f) * static_cast<float>(d + 1);
  std::vector<float> scale(static_cast<size_t>(d));
  for (int i = 0; i < d; ++i) scale[static_cast<size_t>(i)] = inv_std / std::sqrt(static_cast<float>((i + 1) * (i + 2)));
  return scale;
}

void elevate(const float* f, const std::vector<float>& scale, int d, std::vector<float>& cf, std::vector<float>& elevated) {
  for (int i = 0; i < d; ++i) cf[static_cast<size_t>(i)] = f[i] * scale[static_cast<size_t>(i)];
  elevated[static_cast<size_t>(d)] = -static_cast<float>(d) * cf[static_cast<size_t>(d) - 1];
  for (int i = d - 1; i > 0; --i)
    elevated[static_cast<size_t>(i)] = elevated[static_cast<size_t>(i) + 1] - static_cast<float>(i) * cf[static_cast<size_t>(i) - 1] +
                                       static_cast<float>(i + 2) * cf[static_cast<size_t>(i)];
  elevated[0] = elevated[1] + 2.0f * cf[0];
}

// The simplex enclosing an elevated point: the nearest remainder-0 point (coordinates multiples
// of d+1) and the rank of each coordinate's residual, fixed up so that the coordinates sum to zero.
void enclosing_simplex(const std::vector<float>& elevated, int d, std::vector<int32_t>& rem0, std::vector<int32_t>& rank) {
  const int d1 = d + 1;
  const float down = 1.0f / static_cast<float>(d1);
  int sum = 0;
  for (int i = 0; i <= d; ++i) {
    const float v = elevated[static_cast<size_t>(i)] * down;
    const float up = std::ceil(v) * static_cast<float>(d1);
    const float dn = std::floor(v) * static_cast<float>(d1);
    const float e = elevated[static_cast<size_t>(i)];
    rem0[static_cast<size_t>(i)] = static_cast<int32_t>(up - e < e - dn ? up : dn);
    sum += rem0[static_cast<size_t>(i)];
  }
  sum /= d1;
  std::fill(rank.begin(), rank.end(), 0);
  for (int i = 0; i < d; ++i)
    for (int j = i + 1; j <= d; ++j) {
      const float di = elevated[static_cast<size_t>(i)] - static_cast<float>(rem0[static_cast<size_t>(i)]);
      const float dj = elevated[static_cast<size_t>(j)] - static_cast<float>(rem0[static_cast<size_t>(j)]);
      if (di < dj)
        ++rank[static_cast<size_t>(i)];
      else
        ++rank[static_cast<size_t>(j)];
    }
  for (int i = 0; i <= d && sum != 0; ++i) {
    auto& r = rank[static_cast<size_t>(i)];
    if (sum > 0 && r >= d1 - sum) {
      rem0[static_cast<size_t>(i)] -= d1;
      r += sum - d1;
    } else if (sum < 0 && r < -sum) {
      rem0[static_cast<size_t>(i)] += d1;
      r += d1 + sum;
    } else {
      r += sum;
    }
  }
}

// Barycentric coordinates of the elevated point within its simplex (d + 2 values, the last scratch).
void barycentric(const std::vector<float>& elevated, const std::vector<int32_t>& rem0, const std::vector<int32_t>& rank,
                 int d, std::vector<float>& bary) {
  const int d1 = d + 1;
  const float down = 1.0f / static_cast<float>(d1);
  std::fill(bary.begin(), bary.end(), 0.0f);
  for (int i = 0; i <= d; ++i) {
    const float v = (elevated[static_cast<size_t>(i)] - static_cast<float>(rem0[static_cast<size_t>(i)])) * down;
    bary[static_cast<size_t>(d - rank[static_cast<size_t>(i)])] += v;
    bary[static_cast<size_t>(d1 - rank[static_cast<size_t>(i)])] -= v;
  }
  bary[0] += 1.0f + bary[static_cast<size_t>(d1)];
}

// Neighbours of every vertex along each lattice direction j: +-(d+1) e_j -+ 1 in the embedding,
// i.e. coordinate j changes by -+d and every other coordinate by -+1. Absent ones point at an
// extra vertex (index vertex_count) whose values stay zero, so the blur has no branches.
void link_neighbours(const KeyTable& table, int d, int32_t vertex_count, std::vector<int32_t>& neighbour) {
  const int d1 = d + 1;
  neighbour.assign(static_cast<size_t>(vertex_count) * d1 * 2, vertex_count);
  detail::for_range(vertex_count, 512, [&](int64_t v0, int64_t v1) {  // lookups only: any split
    std::vector<int32_t> n1(static_cast<size_t>(d)), n2(static_cast<size_t>(d));
    for (int64_t v = v0; v < v1; ++v) {
      const int32_t* k = table.key(static_cast<int32_t>(v));
      for (int j = 0; j <= d; ++j) {
        for (int i = 0; i < d; ++i) {
          n1[static_cast<size_t>(i)] = k[i] - 1;
          n2[static_cast<size_t>(i)] = k[i] + 1;
        }
        if (j < d) {
          n1[static_cast<size_t>(j)] = k[j] + d;
          n2[static_cast<size_t>(j)] = k[j] - d;
        }
        const size_t base = (static_cast<size_t>(v) * d1 + static_cast<size_t>(j)) * 2;
        const int32_t a = table.find(n1.data()), b = table.find(n2.data());
        neighbour[base] = a >= 0 ? a : vertex_count;
        neighbour[base + 1] = b >= 0 ? b : vertex_count;
      }
    }
  });
}

}  // namespace

void PermutohedralLattice::init(const float* features, int d, int n) {
  if (d < 1 || d > 16) throw Error("permutohedral lattice: dimensions must be in 1..16, got " + std::to_string(d));
  if (n < 0 || (n > 0 && features == nullptr)) throw Error("permutohedral lattice: bad point set");
  d_ = d;
  n_ = n;
  const int d1 = d + 1;
  offset_.assign(static_cast<size_t>(n) * d1, 0);
  barycentric_.assign(static_cast<size_t>(n) * d1, 0.0f);
  const std::vector<float> scale = elevation_scale(d);
  // Each point's simplex (vertex keys and weights) in parallel; then the vertices numbered in point
  // order, as one pass over the points would number them, whatever the split.
  std::vector<int32_t>& keys = keys_;
  keys.resize(static_cast<size_t>(n) * d1 * d);
  detail::for_range(n, 256, [&](int64_t p0, int64_t p1) {
    std::vector<float> elevated(static_cast<size_t>(d1)), bary(static_cast<size_t>(d1) + 1), cf(static_cast<size_t>(d));
    std::vector<int32_t> rem0(static_cast<size_t>(d1)), rank(static_cast<size_t>(d1));
    for (int64_t p = p0; p < p1; ++p) {
      elevate(features + static_cast<size_t>(p) * d, scale, d, cf, elevated);
      enclosing_simplex(elevated, d, rem0, rank);
      barycentric(elevated, rem0, rank, d, bary);
      // The simplex's vertices: remainder-0 point plus the canonical simplex's offsets.
      for (int r = 0; r <= d; ++r) {
        const size_t o = static_cast<size_t>(p) * d1 + static_cast<size_t>(r);
        int32_t* key = keys.data() + o * static_cast<size_t>(d);
        for (int i = 0; i < d; ++i) {
          const int rk = rank[static_cast<size_t>(i)];
          key[i] = rem0[static_cast<size_t>(i)] + (rk <= d - r ? r : r - d1);
        }
        barycentric_[o] = bary[static_cast<size_t>(r)];
      }
    }
  });
  KeyTable table(d, static_cast<size_t>(n) * d1);
  for (size_t o = 0; o < offset_.size(); ++o) offset_[o] = table.insert(keys.data() + o * static_cast<size_t>(d));
  vertex_count_ = table.size();
  link_neighbours(table, d, vertex_count_, neighbour_);
}

void PermutohedralLattice::filter(const float* in, float* out, int v) const {
  if (v < 1) return;
  // Channels are filtered independently (the same operations in the same order per channel), so
  // splitting them into groups that run side by side gives bit-identical output for any split.
  // Each group walks the whole lattice, so groups pay only where threads are plentiful: one per
  // two job-system threads (the CRF runs its two kernels' filters side by side), none on two.
  const int groups = std::clamp(tbb::this_task_arena::max_concurrency() / 2, 1, v);
  if (group_scratch_.size() < static_cast<size_t>(groups)) group_scratch_.resize(static_cast<size_t>(groups));
  detail::for_fixed_chunks(v, groups, [&](int g, int64_t c0, int64_t c1) {
    filter_channels(in, out, v, static_cast<int>(c0), static_cast<int>(c1), group_scratch_[static_cast<size_t>(g)]);
  });
}

void PermutohedralLattice::filter_channels(const float* in, float* out, int v, int c0, int c1, Scratch& s) const {
  const int d1 = d_ + 1;
  const auto stride = static_cast<size_t>(v);
  const auto vs = static_cast<size_t>(c1 - c0);  // channels of this group, stored compactly
  // One extra zero vertex at the end stands for absent neighbours.
  s.values.assign((static_cast<size_t>(vertex_count_) + 1) * vs, 0.0f);
  s.blurred.assign(s.values.size(), 0.0f);
  // Splat (sequential: vertices are shared between points).
  for (int p = 0; p < n_; ++p) {
    const float* x = in + static_cast<size_t>(p) * stride + static_cast<size_t>(c0);
    for (int r = 0; r < d1; ++r) {
      const size_t o = static_cast<size_t>(p) * d1 + static_cast<size_t>(r);
      const float w = barycentric_[o];
      float* dst = s.values.data() + static_cast<size_t>(offset_[o]) * vs;
      for (size_t c = 0; c < vs; ++c) dst[c] += w * x[c];
    }
  }
  // Blur along each direction with [1/2 1 1/2]. Parallel only when a pass is large enough to pay
  // for the task overhead.
  const int64_t grain = std::max<int64_t>(1024, 65536 / static_cast<int64_t>(vs));
  for (int j = 0; j < d1; ++j) {
    detail::for_range(vertex_count_, grain, [&](int64_t v0, int64_t v1) {
      for (int64_t vi = v0; vi < v1; ++vi) {
        const size_t base = (static_cast<size_t>(vi) * d1 + static_cast<size_t>(j)) * 2;
        const float* a = s.values.data() + static_cast<size_t>(neighbour_[base]) * vs;
        const float* b = s.values.data() + static_cast<size_t>(neighbour_[base + 1]) * vs;
        const float* self = s.values.data() + static_cast<size_t>(vi) * vs;
        float* dst = s.blurred.data() + static_cast<size_t>(vi) * vs;
        for (size_t c = 0; c < vs; ++c) dst[c] = self[c] + 0.5f * (a[c] + b[c]);
      }
    });
    s.values.swap(s.blurred);
  }
  // Slice; alpha compensates the blur's gain (Krähenbühl & Koltun's 1 / (1 + 2^-d)).
  const float alpha = 1.0f / (1.0f + std::pow(2.0f, -static_cast<float>(d_)));
  detail::for_range(n_, std::max<int64_t>(1024, 65536 / static_cast<int64_t>(vs * static_cast<size_t>(d1))), [&](int64_t p0, int64_t p1) {
    for (int64_t p = p0; p < p1; ++p) {
      float* y = out + static_cast<size_t>(p) * stride + static_cast<size_t>(c0);
      for (size_t c = 0; c < vs; ++c) y[c] = 0.0f;
      for (int r = 0; r < d1; ++r) {
        const size_t o = static_cast<size_t>(p) * d1 + static_cast<size_t>(r);
        const float w = barycentric_[o] * alpha;
        const float* src = s.values.data() + static_cast<size_t>(offset_[o]) * vs;
        for (size_t c = 0; c < vs; ++c) y[c] += w * src[c];
      }
    }
  });
}

}  // namespace cofusion::segmentation
