#include "slam/motion_reference.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace cofusion::slam::reference {
using glm::vec3;
using glm::vec4;
using kernels::Image;

Image<vec4> mask_vertices(const Image<vec4>& src, const Image<uint32_t>& labels, int level, uint32_t keep_mask,
                          Image<vec4> dst, const PixelRect& rect) {
  const PixelRect r = rect.clamped(src.width, src.height);
  for (int y = r.y0; y < r.y1; ++y)
    for (int x = r.x0; x < r.x1; ++x) {
      const int x0 = std::min(x << level, labels.width - 1), y0 = std::min(y << level, labels.height - 1);
      const uint32_t label = labels.at(x0, y0);
      dst.at(x, y) = label < MASK_VERTICES_NO_LABEL && ((keep_mask >> label) & 1u) != 0u ? src.at(x, y) : vec4(0.0f);
    }
  return dst;
}

Image<vec4> mask_vertices(const Image<vec4>& src, const Image<uint32_t>& labels, int level, uint32_t keep_mask) {
  return mask_vertices(src, labels, level, keep_mask, Image<vec4>(src.width, src.height),
                       PixelRect::full(src.width, src.height));
}

Image<vec4> motion_residuals(const Image<vec4>& live_vertex, const Image<float>& live_intensity,
                             const Image<vec4>& ref_vertex, const Image<vec4>& ref_normal,
                             const Image<float>& ref_intensity, const gpu_layout::MotionResidualParams& p,
                             Image<vec4> out) {
  const float* T = p.T_reference_live;
  const int w = int(p.width), h = int(p.height);
  if (out.width != w || out.height != h) out = Image<vec4>(w, h);
  const PixelRect rect = PixelRect{int(p.rect_x0), int(p.rect_y0), int(std::min(p.rect_x1, p.width)),
                                   int(std::min(p.rect_y1, p.height))}.clamped(w, h);
  for (int i = 0; i < w * h; ++i) {
    if (i % w < rect.x0 || i % w >= rect.x1 || i / w < rect.y0 || i / w >= rect.y1) continue;
    const vec4 v = live_vertex.pixels[size_t(i)];
    if (v.w <= 0.0f) {
      out.pixels[size_t(i)] = vec4(0, 0, 0, MOTION_STATUS_NO_LIVE);
      continue;
    }
    const vec3 q(T[0] * v.x + T[1] * v.y + T[2] * v.z + T[3], T[4] * v.x + T[5] * v.y + T[6] * v.z + T[7],
                 T[8] * v.x + T[9] * v.y + T[10] * v.z + T[11]);
    out.pixels[size_t(i)] = vec4(0, 0, 0, MOTION_STATUS_NO_MODEL);
    if (q.z <= 0.0f) continue;
    const float x = p.fx * q.x / q.z + p.cx, y = p.fy * q.y / q.z + p.cy;
    if (!(x >= -0.5f && y >= -0.5f && x < float(w) - 0.5f && y < float(h) - 0.5f)) continue;
    const int xn = int(std::floor(x + 0.5f)), yn = int(std::floor(y + 0.5f));
    const vec4 r = ref_vertex.at(xn, yn);
    if (r.w <= 0.0f) continue;
    const vec4 n = ref_normal.at(xn, yn);
    const vec3 d = q - vec3(r);
    const float distance_m = n.w > 0.0f ? std::abs(glm::dot(vec3(n), d)) : glm::length(d);
    const float intensity =
        std::abs(ref_intensity.at(xn, yn) - p.live_intensity_gain * live_intensity.pixels[size_t(i)]) / 255.0f;
    out.pixels[size_t(i)] = vec4(distance_m, q.z - r.z, intensity, MOTION_STATUS_ASSOCIATED);
  }
  return out;
}

}  // namespace cofusion::slam::reference
