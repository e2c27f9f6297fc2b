#pragma once
// An axis-aligned rectangle of pixels, half-open: x in [x0, x1), y in [y0, y1). Kernels that only
// have work inside a model's region (its labelled pixels, its predicted footprint) take one so
// that a small object costs in proportion to its size, not to the image's.
#include <algorithm>

namespace cofusion {

struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;

  static PixelRect full(int width, int height) { return {0, 0, width, height}; }
  int width() const { return std::max(0, x1 - x0); }
  int height() const { return std::max(0, y1 - y0); }
  bool empty() const { return width() == 0 || height() == 0; }
  long area() const { return long(width()) * long(height()); }
  bool operator==(const PixelRect&) const = default;

  // Intersection with [0, width) x [0, height); an empty result is {0, 0, 0, 0}.
  PixelRect clamped(int width, int height) const {
    PixelRect r{std::clamp(x0, 0, width), std::clamp(y0, 0, height), std::clamp(x1, 0, width),
                std::clamp(y1, 0, height)};
    return r.empty() ? PixelRect{} : r;
  }
  // The smallest rectangle holding both (an empty one adds nothing).
  PixelRect united(const PixelRect& o) const {
    if (o.empty()) return *this;
    if (empty()) return o;
    return {std::min(x0, o.x0), std::min(y0, o.y0), std::max(x1, o.x1), std::max(y1, o.y1)};
  }
  PixelRect grown(int margin) const { return empty() ? *this : PixelRect{x0 - margin, y0 - margin, x1 + margin, y1 + margin}; }
  // Whether it reaches within `margin` pixels of the border of a width x height image (an empty
  // rectangle does not).
  bool near_border(int width, int height, int margin) const {
    return !empty() && (x0 <= margin || y0 <= margin || x1 >= width - margin || y1 >= height - margin);
  }

  // The rectangle of pyramid level `level` (each level halves the one below) that holds every
  // level pixel (x, y) whose level-0 pixel (x << level, y << level) lies in this one, clamped to
  // the level's size.
  PixelRect at_level(int level, int level_width, int level_height) const {
    if (empty()) return {};
    const int s = 1 << level;
    return PixelRect{x0 >> level, y0 >> level, (x1 + s - 1) >> level, (y1 + s - 1) >> level}.clamped(level_width,
                                                                                                     level_height);
  }
};

}  // namespace cofusion
