#include "segmentation/slic.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "common/error.h"
#include "segmentation/connected_components.h"
#include "segmentation/parallel.h"

namespace cofusion::segmentation {

namespace {

// Fixed row chunks for the centre sums (deterministic whatever the thread count).
constexpr int kChunks = 8;
// Per cluster sums: pixels, x, y, r, g, b, pixels with depth, depth.
constexpr int kSums = 8;

struct Centres {
  std::vector<float> x, y, r, g, b, depth, depth_valid;  // position in the current level's pixels
  void resize(size_t k) {
    for (auto* v : {&x, &y, &r, &g, &b, &depth, &depth_valid}) v->assign(k, 0.0f);
  }
};

// The assignment loop is most of SLIC's time: on x86-64 also build an AVX2 version, picked at
// run time (same IEEE operations in the same order, so both give identical labels).
#if defined(__x86_64__) && defined(__GNUC__)
#define COFUSION_SLIC_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define COFUSION_SLIC_CLONES
#endif

// One row segment [xa, xe) against one cluster; keeps the nearest cluster per pixel. Restrict
// pointers and a mask select (not `d < b ? k : l`) so that GCC vectorises it.
template <bool kDepth>
inline void assign_span(int xa, int xe, const float* __restrict R, const float* __restrict G,
                        const float* __restrict B, const float* __restrict D, const float* __restrict V, float cr,
                        float cg, float cb, float cd, float cdw, float ccx, float base, float spatial_w, int32_t k,
                        float* __restrict bst, int32_t* __restrict lab) {
  for (int x = xa; x < xe; ++x) {
    const float dr = R[x] - cr, dg = G[x] - cg, db = B[x] - cb;
    const float dx = static_cast<float>(x) - ccx;
    float d = dr * dr + dg * dg + db * db + base + spatial_w * dx * dx;
    if constexpr (kDepth) {
      const float dd = D[x] - cd;
      d += cdw * V[x] * dd * dd;
    }
    const float b = bst[x];
    const int32_t better = -static_cast<int32_t>(d < b);
    bst[x] = d < b ? d : b;
    lab[x] = (k & better) | (lab[x] & ~better);
  }
}

// One image resolution: float planes (so the distance loop vectorises; depth_valid is 0/1 to keep
// it branch-free) and the grid of cluster cells over it.
struct Level {
  int width = 0, height = 0;
  float scale = 1;  // full-resolution pixels per pixel of this level
  std::vector<float> r, g, b, depth, depth_valid, best;
  std::vector<int32_t> assignment;
  std::vector<int> xb, yb;  // cell boundaries: columns [xb[c], xb[c+1]), rows [yb[c], yb[c+1])
  void resize(int w, int h, bool with_depth) {
    width = w;
    height = h;
    const auto n = static_cast<size_t>(w) * static_cast<size_t>(h);
    for (auto* v : {&r, &g, &b, &best}) v->resize(n);
    depth.resize(with_depth ? n : 0);
    depth_valid.resize(with_depth ? n : 0);
    assignment.resize(n);
  }
  void set_grid(int gw, int gh) {
    xb.resize(static_cast<size_t>(gw) + 1);
    yb.resize(static_cast<size_t>(gh) + 1);
    for (int c = 0; c <= gw; ++c) xb[static_cast<size_t>(c)] = static_cast<int>(static_cast<int64_t>(c) * width / gw);
    for (int c = 0; c <= gh; ++c) yb[static_cast<size_t>(c)] = static_cast<int>(static_cast<int64_t>(c) * height / gh);
  }
};

// Every pixel of cell (cx, cy) rows [ya, ye) against the 3x3 clusters around the cell, in a fixed
// order (ties keep the first), so the result does not depend on how rows are split.
COFUSION_SLIC_CLONES
void assign_cell(bool with_depth, Level& lv, const Centres& c, int gw, int gh, int cx, int cy, int ya, int ye,
                 float spatial_w, float depth_w) {
  const int xa = lv.xb[static_cast<size_t>(cx)], xe = lv.xb[static_cast<size_t>(cx) + 1];
  const auto w = static_cast<size_t>(lv.width);
  for (int y = ya; y < ye; ++y) std::fill(lv.best.begin() + static_cast<std::ptrdiff_t>(y * w + static_cast<size_t>(xa)),
                                          lv.best.begin() + static_cast<std::ptrdiff_t>(y * w + static_cast<size_t>(xe)),
                                          std::numeric_limits<float>::max());
  for (int ry = std::max(0, cy - 1); ry <= std::min(gh - 1, cy + 1); ++ry)
    for (int rx = std::max(0, cx - 1); rx <= std::min(gw - 1, cx + 1); ++rx) {
      const int32_t k = ry * gw + rx;
      const auto u = static_cast<size_t>(k);
      const float cd = with_depth ? c.depth[u] : 0.0f;
      const float cdw = with_depth ? c.depth_valid[u] * depth_w : 0.0f;
      for (int y = ya; y < ye; ++y) {
        const size_t row = static_cast<size_t>(y) * w;
        const float dy = static_cast<float>(y) - c.y[u];
        const float base = spatial_w * dy * dy;
        if (with_depth)
          assign_span<true>(xa, xe, lv.r.data() + row, lv.g.data() + row, lv.b.data() + row, lv.depth.data() + row,
                            lv.depth_valid.data() + row, c.r[u], c.g[u], c.b[u], cd, cdw, c.x[u], base, spatial_w, k,
                            lv.best.data() + row, lv.assignment.data() + row);
        else
          assign_span<false>(xa, xe, lv.r.data() + row, lv.g.data() + row, lv.b.data() + row, nullptr, nullptr,
                             c.r[u], c.g[u], c.b[u], 0.0f, 0.0f, c.x[u], base, spatial_w, k, lv.best.data() + row,
                             lv.assignment.data() + row);
      }
    }
}

void check_params(const SlicParams& p) {
  if (p.superpixel_size_px < 1)
    throw Error("SLIC: superpixel_size_px must be >= 1, got " + std::to_string(p.superpixel_size_px));
  if (!(p.compactness > 0) || !std::isfinite(p.compactness))
    throw Error("SLIC: compactness must be positive and finite, got " + std::to_string(p.compactness));
  if (p.iterations < 1) throw Error("SLIC: iterations must be >= 1, got " + std::to_string(p.iterations));
  if (!(p.depth_weight_per_m >= 0) || !std::isfinite(p.depth_weight_per_m))
    throw Error("SLIC: depth_weight_per_m must be >= 0 and finite, got " + std::to_string(p.depth_weight_per_m));
  if (!(p.min_piece_fraction >= 0) || !(p.min_piece_fraction <= 1))
    throw Error("SLIC: min_piece_fraction must be in [0, 1], got " + std::to_string(p.min_piece_fraction));
}

// The grid of cluster seeds over the image, in full-resolution pixels, and the distance weights.
struct Grid {
  int gw = 1, gh = 1, K = 1;     // cells across, down, and their count
  float step_x = 1, step_y = 1;  // cell size (pixels)
  bool use_depth = false;
  float depth_w = 0;  // weight of a squared depth difference (1/m^2)

  static Grid make(int width, int height, const SlicParams& p) {
    Grid g;
    const int S = p.superpixel_size_px;
    g.gw = std::max(1, static_cast<int>(std::lround(static_cast<double>(width) / S)));
    g.gh = std::max(1, static_cast<int>(std::lround(static_cast<double>(height) / S)));
    g.K = g.gw * g.gh;
    g.step_x = static_cast<float>(width) / static_cast<float>(g.gw);
    g.step_y = static_cast<float>(height) / static_cast<float>(g.gh);
    g.use_depth = p.depth_weight_per_m > 0;
    g.depth_w = p.depth_weight_per_m * p.depth_weight_per_m;
    return g;
  }
};

// The input as float planes at full resolution (depth 0 and depth_valid 0 where there is none).
void load_full_level(const uint8_t* rgb, const float* depth_m, int width, int height, const Grid& g, Level& full) {
  full.resize(width, height, g.use_depth);
  full.scale = 1;
  full.set_grid(g.gw, g.gh);
  detail::for_range(static_cast<int64_t>(width) * height, 16384, [&](int64_t i0, int64_t i1) {
    for (int64_t i = i0; i < i1; ++i) {
      const auto u = static_cast<size_t>(i);
      full.r[u] = rgb[3 * u];
      full.g[u] = rgb[3 * u + 1];
      full.b[u] = rgb[3 * u + 2];
      if (g.use_depth) {
        const float d = depth_m[u];
        const bool ok = std::isfinite(d) && d > 0;
        full.depth[u] = ok ? d : 0.0f;
        full.depth_valid[u] = ok ? 1.0f : 0.0f;
      }
    }
  });
}

// Half resolution: 2x2 means; depth the mean of the valid readings.
void downsample_level(const Level& full, const Grid& g, Level& half) {
  half.resize(full.width / 2, full.height / 2, g.use_depth);
  half.scale = 2;
  half.set_grid(g.gw, g.gh);
  const int hw = half.width;
  const auto width = static_cast<size_t>(full.width);
  detail::for_range(half.height, 16, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < hw; ++x) {
        const size_t a = static_cast<size_t>(2 * y) * width + static_cast<size_t>(2 * x);
        const size_t b = a + width;
        const size_t h = static_cast<size_t>(y) * static_cast<size_t>(hw) + static_cast<size_t>(x);
        half.r[h] = 0.25f * (full.r[a] + full.r[a + 1] + full.r[b] + full.r[b + 1]);
        half.g[h] = 0.25f * (full.g[a] + full.g[a + 1] + full.g[b] + full.g[b + 1]);
        half.b[h] = 0.25f * (full.b[a] + full.b[a + 1] + full.b[b] + full.b[b + 1]);
        if (g.use_depth) {
          const float nv = full.depth_valid[a] + full.depth_valid[a + 1] + full.depth_valid[b] + full.depth_valid[b + 1];
          const float sd = full.depth[a] + full.depth[a + 1] + full.depth[b] + full.depth[b + 1];
          half.depth[h] = nv > 0 ? sd / nv : 0.0f;
          half.depth_valid[h] = nv > 0 ? 1.0f : 0.0f;
        }
      }
  });
}

// Local k-means over one level: pixels are assigned to the nearest of the 3x3 centres around
// their cell, and the centres move to the mean of their pixels. Sums are made per fixed row chunk
// and added in chunk order, so the result does not depend on the thread count.
class Clustering {
 public:
  Clustering(const Grid& grid, const SlicParams& params, Centres& centres, std::vector<double>& partial)
      : g_(grid), params_(params), c_(centres), partial_(partial) {
    c_.resize(static_cast<size_t>(g_.K));
    partial_.resize(static_cast<size_t>(kChunks) * static_cast<size_t>(g_.K) * kSums);
  }

  // Seeds: every pixel in its grid cell, each centre the mean of its cell.
  void seed(Level& lv) {
    std::fill(partial_.begin(), partial_.end(), 0.0);
    detail::for_fixed_chunks(lv.height, kChunks, [&](int chunk, int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y) {
        int cy = 0;
        while (lv.yb[static_cast<size_t>(cy) + 1] <= y) ++cy;
        for (int cx = 0; cx < g_.gw; ++cx)
          for (int x = lv.xb[static_cast<size_t>(cx)]; x < lv.xb[static_cast<size_t>(cx) + 1]; ++x)
            lv.assignment[static_cast<size_t>(y) * static_cast<size_t>(lv.width) + static_cast<size_t>(x)] = cy * g_.gw + cx;
      }
      accumulate_rows(lv, chunk, static_cast<int>(y0), static_cast<int>(y1));
    });
    update_centres();
  }

  // Assigns every pixel of `lv` to its nearest candidate cluster (a pixel's choice does not depend
  // on the split of rows, so they go to as many threads as there are), then optionally sums the
  // clusters for the next update (in the fixed row chunks, whose order fixes the sums).
  void assign(Level& lv, bool accumulate) {
    const float step = 0.5f * (g_.step_x + g_.step_y) / lv.scale;  // grid step in this level's pixels
    const float spatial_w = (params_.compactness / step) * (params_.compactness / step);
    detail::for_range(g_.gh, 1, [&](int64_t cy0, int64_t cy1) {  // rows of cells
      for (auto cy = static_cast<int>(cy0); cy < cy1; ++cy) {
        const int ya = lv.yb[static_cast<size_t>(cy)], ye = lv.yb[static_cast<size_t>(cy) + 1];
        for (int cx = 0; cx < g_.gw; ++cx)
          assign_cell(g_.use_depth, lv, c_, g_.gw, g_.gh, cx, cy, ya, ye, spatial_w, g_.depth_w);
      }
    });
    if (!accumulate) return;
    std::fill(partial_.begin(), partial_.end(), 0.0);
    detail::for_fixed_chunks(lv.height, kChunks, [&](int chunk, int64_t y0, int64_t y1) {
      accumulate_rows(lv, chunk, static_cast<int>(y0), static_cast<int>(y1));
    });
  }

  // Each centre the mean of its pixels' sums (an empty cluster keeps its centre).
  void update_centres() {
    const auto K = static_cast<size_t>(g_.K);
    detail::for_range(g_.K, 256, [&](int64_t k0, int64_t k1) {
      for (int64_t k = k0; k < k1; ++k) {
        double sum[kSums] = {};
        for (int ch = 0; ch < kChunks; ++ch) {
          const double* a = partial_.data() + (static_cast<size_t>(ch) * K + static_cast<size_t>(k)) * kSums;
          for (int j = 0; j < kSums; ++j) sum[j] += a[j];
        }
        if (sum[0] <= 0) continue;
        const auto u = static_cast<size_t>(k);
        c_.x[u] = static_cast<float>(sum[1] / sum[0]);
        c_.y[u] = static_cast<float>(sum[2] / sum[0]);
        c_.r[u] = static_cast<float>(sum[3] / sum[0]);
        c_.g[u] = static_cast<float>(sum[4] / sum[0]);
        c_.b[u] = static_cast<float>(sum[5] / sum[0]);
        c_.depth_valid[u] = sum[6] > 0 ? 1.0f : 0.0f;
        c_.depth[u] = sum[6] > 0 ? static_cast<float>(sum[7] / sum[6]) : 0.0f;
      }
    });
  }

  // Half-resolution centres to full-resolution coordinates (half pixel i covers full pixels 2i, 2i+1).
  void centres_to_full_resolution() {
    for (size_t k = 0; k < static_cast<size_t>(g_.K); ++k) {
      c_.x[k] = 2.0f * c_.x[k] + 0.5f;
      c_.y[k] = 2.0f * c_.y[k] + 0.5f;
    }
  }

 private:
  // Adds the pixels of rows [y0, y1) of `lv` to chunk `chunk`'s cluster sums.
  void accumulate_rows(const Level& lv, int chunk, int y0, int y1) {
    double* acc = partial_.data() + static_cast<size_t>(chunk) * static_cast<size_t>(g_.K) * kSums;
    const int w = lv.width;
    for (int y = y0; y < y1; ++y) {
      const size_t row = static_cast<size_t>(y) * static_cast<size_t>(w);
      int x = 0;
      while (x < w) {
        const int32_t k = lv.assignment[row + static_cast<size_t>(x)];
        // Sum a run of equal labels locally, then flush once.
        float sr = 0, sg = 0, sb = 0, sd = 0, nd = 0;
        const int xs = x;
        for (; x < w && lv.assignment[row + static_cast<size_t>(x)] == k; ++x) {
          const size_t u = row + static_cast<size_t>(x);
          sr += lv.r[u];
          sg += lv.g[u];
          sb += lv.b[u];
          if (g_.use_depth) {
            sd += lv.depth[u];
            nd += lv.depth_valid[u];
          }
        }
        const double len = x - xs;
        double* a = acc + static_cast<size_t>(k) * kSums;
        a[0] += len;
        a[1] += len * (xs + x - 1) * 0.5;
        a[2] += len * y;
        a[3] += sr;
        a[4] += sg;
        a[5] += sb;
        a[6] += nd;
        a[7] += sd;
      }
    }
  }

  const Grid& g_;
  const SlicParams& params_;
  Centres& c_;
  std::vector<double>& partial_;
};

// Connectivity: every 4-connected piece of a cluster is a candidate superpixel; a piece below
// min_piece_fraction of the nominal area joins the adjacent piece of closest mean colour and
// depth (preferring pieces that are large enough), so no superpixel is split and small slivers
// do not cross colour edges.
class PieceMerger {
 public:
  PieceMerger(const Level& full, const Grid& grid, const SlicParams& params, const ComponentLabelling& cc)
      : full_(full), g_(grid), cc_(cc), pieces_(static_cast<int32_t>(cc.components.size())),
        min_piece_px_(params.min_piece_fraction * static_cast<double>(grid.step_x) * grid.step_y) {}

  Superpixels run() {
    sum_pieces();
    find_best_neighbours();
    return label(number_superpixels());
  }

 private:
  struct Best {
    int32_t piece = -1;
    double distance = 0;
  };

  // r, g, b, depth and depth count summed per piece (per run in parallel, then in run order).
  void sum_pieces() {
    const auto run_count = cc_.runs.size();
    std::vector<float> run_sums(run_count * 5);
    const auto width = static_cast<size_t>(full_.width);
    detail::for_range(static_cast<int64_t>(run_count), 1024, [&](int64_t a, int64_t e) {
      for (int64_t i = a; i < e; ++i) {
        const LabelRun& run = cc_.runs[static_cast<size_t>(i)];
        const auto row = static_cast<size_t>(run.y) * width;
        float sum[5] = {};
        for (int x = run.x0; x < run.x1; ++x) {
          const size_t u = row + static_cast<size_t>(x);
          sum[0] += full_.r[u];
          sum[1] += full_.g[u];
          sum[2] += full_.b[u];
          if (g_.use_depth) {
            sum[3] += full_.depth[u];
            sum[4] += full_.depth_valid[u];
          }
        }
        std::copy(sum, sum + 5, run_sums.begin() + static_cast<std::ptrdiff_t>(i) * 5);
      }
    });
    sums_.assign(static_cast<size_t>(pieces_) * 5, 0.0);
    for (size_t i = 0; i < run_count; ++i)
      for (int j = 0; j < 5; ++j)
        sums_[static_cast<size_t>(cc_.runs[i].component) * 5 + static_cast<size_t>(j)] += run_sums[i * 5 + static_cast<size_t>(j)];
  }

  bool is_small(int32_t p) const { return static_cast<double>(cc_.components[static_cast<size_t>(p)].pixels) < min_piece_px_; }

  double distance(int32_t a, int32_t b) const {
    const double* sa = &sums_[static_cast<size_t>(a) * 5];
    const double* sb = &sums_[static_cast<size_t>(b) * 5];
    const double na = static_cast<double>(cc_.components[static_cast<size_t>(a)].pixels);
    const double nb = static_cast<double>(cc_.components[static_cast<size_t>(b)].pixels);
    double d = 0;
    for (int j = 0; j < 3; ++j) {
      const double e = sa[j] / na - sb[j] / nb;
      d += e * e;
    }
    if (g_.use_depth && sa[4] > 0 && sb[4] > 0) {
      const double e = sa[3] / sa[4] - sb[3] / sb[4];
      d += g_.depth_w * e * e;
    }
    return d;
  }

  // For a small piece p, neighbour q as a candidate (ties: the lower piece index).
  void consider(int32_t p, int32_t q) {
    if (p == q || !is_small(p)) return;
    const double d = distance(p, q);
    Best& b = is_small(q) ? best_small_[static_cast<size_t>(p)] : best_large_[static_cast<size_t>(p)];
    if (b.piece < 0 || d < b.distance || (d == b.distance && q < b.piece)) b = {q, d};
  }

  void find_best_neighbours() {
    best_large_.assign(static_cast<size_t>(pieces_), Best{});
    best_small_.assign(static_cast<size_t>(pieces_), Best{});
    for (int y = 0; y < full_.height; ++y) {
      const int32_t a0 = cc_.row_begin[static_cast<size_t>(y)], a1 = cc_.row_begin[static_cast<size_t>(y) + 1];
      for (int32_t a = a0; a + 1 < a1; ++a) {  // horizontal neighbours (runs tile the row)
        const int32_t p = cc_.runs[static_cast<size_t>(a)].component, q = cc_.runs[static_cast<size_t>(a) + 1].component;
        consider(p, q);
        consider(q, p);
      }
      if (y == 0) continue;
      for_each_overlapping_run_pair(cc_.runs, cc_.row_begin, y, [&](int32_t ia, int32_t ib) {
        const int32_t p = cc_.runs[static_cast<size_t>(ia)].component, q = cc_.runs[static_cast<size_t>(ib)].component;
        consider(p, q);
        consider(q, p);
      });
    }
  }

  // Small pieces joined to their best neighbours; superpixels numbered in raster order of their
  // first pixel (roots are the smallest piece index of their set, and pieces are numbered in
  // raster order). Returns the superpixel of each piece.
  std::vector<int32_t> number_superpixels() {
    UnionFind uf;
    uf.reset(pieces_);
    for (int32_t p = 0; p < pieces_; ++p) {
      const auto u = static_cast<size_t>(p);
      const Best& b = best_large_[u].piece >= 0 ? best_large_[u] : best_small_[u];
      if (b.piece >= 0) uf.unite(p, b.piece);
    }
    std::vector<int32_t> final_id(static_cast<size_t>(pieces_), -1);
    count_ = 0;
    for (int32_t p = 0; p < pieces_; ++p) {
      const int32_t root = uf.find(p);
      if (root == p) final_id[static_cast<size_t>(p)] = count_++;
      final_id[static_cast<size_t>(p)] = final_id[static_cast<size_t>(root)];
    }
    return final_id;
  }

  Superpixels label(const std::vector<int32_t>& final_id) const {
    Superpixels out;
    out.width = full_.width;
    out.height = full_.height;
    out.count = count_;
    out.step_x_px = g_.step_x;
    out.step_y_px = g_.step_y;
    out.label.resize(static_cast<size_t>(full_.width) * static_cast<size_t>(full_.height));
    detail::for_range(static_cast<int64_t>(cc_.runs.size()), 1024, [&](int64_t a, int64_t e) {
      for (int64_t i = a; i < e; ++i) {
        const LabelRun& run = cc_.runs[static_cast<size_t>(i)];
        const int32_t id = final_id[static_cast<size_t>(run.component)];
        std::fill_n(out.label.begin() + static_cast<std::ptrdiff_t>(run.y) * full_.width + run.x0, run.x1 - run.x0, id);
      }
    });
    return out;
  }

  const Level& full_;
  const Grid& g_;
  const ComponentLabelling& cc_;
  const int32_t pieces_;
  const double min_piece_px_;
  std::vector<double> sums_;
  std::vector<Best> best_large_, best_small_;
  int32_t count_ = 0;
};

}  // namespace

struct Slic::Scratch {
  Level full, half;
  Centres centres;
  std::vector<double> partial;  // per chunk and cluster sums
  ComponentLabelling components;
};

Slic::Slic() : scratch_(std::make_unique<Scratch>()) {}
Slic::~Slic() = default;
Slic::Slic(Slic&&) noexcept = default;
Slic& Slic::operator=(Slic&&) noexcept = default;

Superpixels Slic::compute(const uint8_t* rgb, const float* depth_m, int width, int height,
                          const SlicParams& params) {
  if (width <= 0 || height <= 0)
    throw Error("SLIC: image size must be positive, got " + std::to_string(width) + "x" + std::to_string(height));
  if (rgb == nullptr) throw Error("SLIC: rgb image pointer is null");
  if (depth_m == nullptr && params.depth_weight_per_m > 0)
    throw Error("SLIC: depth image pointer is null (set depth_weight_per_m = 0 to run on colour only)");
  check_params(params);
  const auto t0 = std::chrono::steady_clock::now();
  Scratch& s = *scratch_;
  const Grid grid = Grid::make(width, height, params);
  load_full_level(rgb, depth_m, width, height, grid, s.full);
  // Coarse to fine: the iterations run at half resolution, then every full-resolution pixel is
  // assigned once to the centres moved to full-resolution coordinates. Without it the last
  // iteration's assignment is the result.
  const bool coarse = params.coarse_to_fine && grid.step_x >= 8 && grid.step_y >= 8;
  if (coarse) downsample_level(s.full, grid, s.half);
  Level& work = coarse ? s.half : s.full;

  Clustering clustering(grid, params, s.centres, s.partial);
  clustering.seed(work);
  for (int it = 0; it < params.iterations; ++it) {
    const bool last = it + 1 == params.iterations;
    clustering.assign(work, !last || coarse);
    if (!last || coarse) clustering.update_centres();
  }
  if (coarse) {
    clustering.centres_to_full_resolution();
    clustering.assign(s.full, false);
  }
  clustering_ms_ = detail::ms_since(t0);

  const auto t1 = std::chrono::steady_clock::now();
  label_components<int32_t>(s.full.assignment.data(), width, height, std::nullopt, s.components);
  Superpixels out = PieceMerger(s.full, grid, params, s.components).run();
  connectivity_ms_ = detail::ms_since(t1);
  return out;
}

Superpixels compute_slic(const uint8_t* rgb, const float* depth_m, int width, int height,
                         const SlicParams& params) {
  Slic slic;
  return slic.compute(rgb, depth_m, width, height, params);
}

}  // namespace cofusion::segmentation
