#pragma once
// Pinhole camera intrinsics in pixels, with the image size they belong to.
#include <cmath>
#include <string>

namespace cofusion {

struct Intrinsics {
  double fx = 525.0;  // focal length, pixels
  double fy = 525.0;
  double cx = 319.5;  // principal point, pixels (pixel centres at integer coordinates)
  double cy = 239.5;
  int width = 640;    // image size, pixels
  int height = 480;

  // Intrinsics of pyramid level `level` where each level halves the previous one (2x2 blocks):
  // a pixel centre x at level l+1 covers x' = 2x + 0.5 at level l.
  Intrinsics at_level(int level) const {
    Intrinsics k = *this;
    for (int l = 0; l < level; ++l) {
      k.fx *= 0.5;
      k.fy *= 0.5;
      k.cx = (k.cx - 0.5) * 0.5;
      k.cy = (k.cy - 0.5) * 0.5;
      k.width = k.width / 2 > 0 ? k.width / 2 : 1;
      k.height = k.height / 2 > 0 ? k.height / 2 : 1;
    }
    return k;
  }

  bool plausible() const {
    return std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) && std::isfinite(cy) && fx > 0 &&
           fy > 0 && width > 0 && height > 0 && cx > -width && cx < 2.0 * width && cy > -height &&
           cy < 2.0 * height;
  }

  std::string to_string() const {
    return "fx=" + std::to_string(fx) + " fy=" + std::to_string(fy) + " cx=" + std::to_string(cx) +
           " cy=" + std::to_string(cy) + " " + std::to_string(width) + "x" + std::to_string(height);
  }
};

}  // namespace cofusion
