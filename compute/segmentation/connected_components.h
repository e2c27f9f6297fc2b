#pragma once
// 4-connected components of a label image, computed on horizontal runs of equal labels (a
// union-find over runs, so the cost is one pass over the pixels plus one over the runs).
// Used by SLIC (to make every superpixel connected) and by the segmentation post-processing.
#include <cstdint>
#include <optional>
#include <vector>

namespace cofusion::segmentation {

// A maximal horizontal run [x0, x1) of row y whose pixels carry the same label value.
struct LabelRun {
  int32_t y = 0, x0 = 0, x1 = 0;
  int32_t value = 0;      // the label of its pixels
  int32_t component = 0;  // index into ComponentLabelling::components
};

struct ComponentInfo {
  int32_t value = 0;   // the label shared by its pixels
  int64_t pixels = 0;  // pixel count
  int32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // bounding box: [x0, x1) x [y0, y1), pixels
};

struct ComponentLabelling {
  int width = 0, height = 0;
  std::vector<LabelRun> runs;         // in raster order
  std::vector<int32_t> row_begin;     // runs of row y: [row_begin[y], row_begin[y + 1])
  // Components numbered in raster order of their first pixel (deterministic).
  std::vector<ComponentInfo> components;
};

// Calls f(a, b) for every run index a of row y (y >= 1) and b of row y - 1 whose x ranges overlap
// (vertically 4-connected runs, whatever their values), walking both rows once.
template <class F>
void for_each_overlapping_run_pair(const std::vector<LabelRun>& runs, const std::vector<int32_t>& row_begin, int y,
                                   F&& f) {
  int32_t a = row_begin[static_cast<size_t>(y)];
  const int32_t a_end = row_begin[static_cast<size_t>(y) + 1];
  int32_t b = row_begin[static_cast<size_t>(y) - 1];
  const int32_t b_end = row_begin[static_cast<size_t>(y)];
  while (a < a_end && b < b_end) {
    const LabelRun& ra = runs[static_cast<size_t>(a)];
    const LabelRun& rb = runs[static_cast<size_t>(b)];
    if (ra.x0 < rb.x1 && rb.x0 < ra.x1) f(a, b);
    // Advance whichever run ends first (both when they end together).
    const bool advance_a = ra.x1 <= rb.x1, advance_b = rb.x1 <= ra.x1;
    a += advance_a;
    b += advance_b;
  }
}

// Labels the 4-connected components of `labels` (width*height values, row-major). Pixels equal to
// `ignore` (when given) belong to no run and no component. Reuses `out`'s storage.
// Instantiated for int32_t and uint8_t.
template <class T>
void label_components(const T* labels, int width, int height, std::optional<T> ignore,
                      ComponentLabelling& out);

// Minimal union-find with path halving; unions keep the smaller index as the root so that roots
// (and everything derived from them) do not depend on the order of the unions.
class UnionFind {
 public:
  void reset(int32_t n) {
    parent_.resize(static_cast<size_t>(n));
    for (int32_t i = 0; i < n; ++i) parent_[static_cast<size_t>(i)] = i;
  }
  int32_t find(int32_t a) {
    while (parent_[static_cast<size_t>(a)] != a) {
      auto& p = parent_[static_cast<size_t>(a)];
      p = parent_[static_cast<size_t>(p)];
      a = p;
    }
    return a;
  }
  void unite(int32_t a, int32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (a < b)
      parent_[static_cast<size_t>(b)] = a;
    else
      parent_[static_cast<size_t>(a)] = b;
  }

 private:
  std::vector<int32_t> parent_;
};

}  // namespace cofusion::segmentation
