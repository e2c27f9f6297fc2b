#pragma once
// A plain row-major CPU image, used by the CPU reference kernels and the tests that compare them
// with the GPU. GPU images live in storage buffers with the same layout.
#include <cstddef>
#include <vector>

namespace cofusion::kernels {

template <typename T>
struct Image {
  int width = 0;
  int height = 0;
  std::vector<T> pixels;

  Image() = default;
  Image(int w, int h, T fill = T{}) : width(w), height(h), pixels(static_cast<size_t>(w) * h, fill) {}
  T& at(int x, int y) { return pixels[static_cast<size_t>(y) * width + x]; }
  const T& at(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
  size_t size() const { return pixels.size(); }
  size_t bytes() const { return pixels.size() * sizeof(T); }
};

// Size of pyramid level l+1 from level l: halved, at least 1.
inline int half_size(int n) { return n / 2 > 0 ? n / 2 : 1; }

}  // namespace cofusion::kernels
