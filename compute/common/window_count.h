#pragma once
// Counts of marked cells in square windows of a grid, in constant time per query (an integral
// image: one pass to build, four look-ups per window).
#include <algorithm>
#include <cstdint>
#include <vector>

namespace cofusion {

class WindowCount {
 public:
  // marked(x, y) for x in [0, width), y in [0, height).
  template <typename Marked>
  WindowCount(int width, int height, const Marked& marked)
      : width_(std::max(width, 0)), height_(std::max(height, 0)), sums_(size_t(width_ + 1) * size_t(height_ + 1), 0) {
    for (int y = 0; y < height_; ++y) {
      int32_t row = 0;
      for (int x = 0; x < width_; ++x) {
        row += marked(x, y) ? 1 : 0;
        at(x + 1, y + 1) = at(x + 1, y) + row;
      }
    }
  }

  // Marked cells in the window of half-size `reach` around (x, y), clipped to the grid.
  int32_t around(int x, int y, int reach) const {
    const int x0 = std::clamp(x - reach, 0, width_), y0 = std::clamp(y - reach, 0, height_);
    const int x1 = std::clamp(x + reach + 1, 0, width_), y1 = std::clamp(y + reach + 1, 0, height_);
    if (x1 <= x0 || y1 <= y0) return 0;
    return at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0);
  }

 private:
  int32_t& at(int x, int y) { return sums_[size_t(y) * size_t(width_ + 1) + size_t(x)]; }
  int32_t at(int x, int y) const { return sums_[size_t(y) * size_t(width_ + 1) + size_t(x)]; }

  int width_, height_;
  std::vector<int32_t> sums_;
};

}  // namespace cofusion
