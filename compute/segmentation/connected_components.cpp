#include "segmentation/connected_components.h"

#include <algorithm>

#include "segmentation/parallel.h"

namespace cofusion::segmentation {

namespace {

template <class T>
int32_t count_row_runs(const T* row, int width, std::optional<T> ignore) {
  int32_t runs = 0;
  int x = 0;
  while (x < width) {
    const T v = row[x];
    int e = x + 1;
    while (e < width && row[e] == v) ++e;
    if (!ignore || v != *ignore) ++runs;
    x = e;
  }
  return runs;
}

}  // namespace

template <class T>
void label_components(const T* labels, int width, int height, std::optional<T> ignore,
                      ComponentLabelling& out) {
  out.width = width;
  out.height = height;
  out.row_begin.assign(static_cast<size_t>(height) + 1, 0);
  out.components.clear();
  const auto row_ptr = [&](int y) { return labels + static_cast<int64_t>(y) * width; };

  // Runs: count per row, prefix sum, fill (rows in parallel; the layout is fixed by the counts).
  detail::for_range(height, 16, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      out.row_begin[static_cast<size_t>(y) + 1] = count_row_runs(row_ptr(static_cast<int>(y)), width, ignore);
  });
  for (int y = 0; y < height; ++y) out.row_begin[static_cast<size_t>(y) + 1] += out.row_begin[static_cast<size_t>(y)];
  out.runs.resize(static_cast<size_t>(out.row_begin[static_cast<size_t>(height)]));
  detail::for_range(height, 16, [&](int64_t y0, int64_t y1) {
    for (int64_t yy = y0; yy < y1; ++yy) {
      const int y = static_cast<int>(yy);
      const T* row = row_ptr(y);
      int32_t r = out.row_begin[static_cast<size_t>(y)];
      int x = 0;
      while (x < width) {
        const T v = row[x];
        int e = x + 1;
        while (e < width && row[e] == v) ++e;
        if (!ignore || v != *ignore) out.runs[static_cast<size_t>(r++)] = {y, x, e, static_cast<int32_t>(v), 0};
        x = e;
      }
    }
  });

  // Union runs that overlap the previous row's runs with the same value.
  const auto run_count = static_cast<int32_t>(out.runs.size());
  UnionFind uf;
  uf.reset(run_count);
  for (int y = 1; y < height; ++y)
    for_each_overlapping_run_pair(out.runs, out.row_begin, y, [&](int32_t a, int32_t b) {
      if (out.runs[static_cast<size_t>(a)].value == out.runs[static_cast<size_t>(b)].value) uf.unite(a, b);
    });

  // Components in raster order of their first run; statistics.
  std::vector<int32_t> root_component(static_cast<size_t>(run_count), -1);
  for (int32_t r = 0; r < run_count; ++r) {
    LabelRun& run = out.runs[static_cast<size_t>(r)];
    const int32_t root = uf.find(r);
    int32_t& c = root_component[static_cast<size_t>(root)];
    if (c < 0) {
      c = static_cast<int32_t>(out.components.size());
      out.components.push_back({run.value, 0, run.x0, run.y, run.x1, run.y + 1});
    }
    run.component = c;
    ComponentInfo& info = out.components[static_cast<size_t>(c)];
    info.pixels += run.x1 - run.x0;
    info.x0 = std::min(info.x0, run.x0);
    info.x1 = std::max(info.x1, run.x1);
    info.y1 = std::max(info.y1, run.y + 1);
  }
}

template void label_components<int32_t>(const int32_t*, int, int, std::optional<int32_t>, ComponentLabelling&);
template void label_components<uint8_t>(const uint8_t*, int, int, std::optional<uint8_t>, ComponentLabelling&);

}  // namespace cofusion::segmentation
