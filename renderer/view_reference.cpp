// CPU reference of view_splat.comp + view_resolve.comp: the same float arithmetic in the same
// order, so GPU and CPU differ only by rounding (a pixel on a footprint border, +-1 in a channel).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>

#include "common/error.h"
#include "renderer/view_renderer.h"
#include "shared/view_shading.h"

namespace cofusion::renderer {

namespace {
struct Vec3f {
  float x, y, z;
};
Vec3f rotate(const float T[12], float x, float y, float z) {
  return {T[0] * x + T[1] * y + T[2] * z, T[4] * x + T[5] * y + T[6] * z, T[8] * x + T[9] * y + T[10] * z};
}
Vec3f apply(const float T[12], float x, float y, float z) {
  const Vec3f r = rotate(T, x, y, z);
  return {r.x + T[3], r.y + T[7], r.z + T[11]};
}
uint32_t float_bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}
}  // namespace

Image render_reference(std::span<const SurfelCloud> clouds, const VirtualCamera& camera, const RenderParams& params) {
  const auto& K = camera.intrinsics;
  if (!K.plausible()) throw Error("view reference: implausible virtual camera intrinsics (" + K.to_string() + ")");
  const int w = K.width, h = K.height;
  const float fx = static_cast<float>(K.fx), fy = static_cast<float>(K.fy);
  const float cx = static_cast<float>(K.cx), cy = static_cast<float>(K.cy);
  constexpr uint64_t empty = std::numeric_limits<uint64_t>::max();
  std::vector<uint64_t> grid(static_cast<size_t>(w) * h, empty);
  const Eigen::Isometry3d T_view_world = camera.T_world_view.inverse();
  std::vector<std::array<float, 12>> T_view_model(clouds.size());
  std::vector<uint32_t> bases(clouds.size());

  uint32_t base = 0;
  for (size_t m = 0; m < clouds.size(); ++m) {
    to_rows_3x4(T_view_world * clouds[m].T_world_model, T_view_model[m].data());
    bases[m] = base;
    const float* T = T_view_model[m].data();
    const auto& surfels = clouds[m].surfels;
    for (uint32_t i = 0; i < surfels.size(); ++i) {
      const Surfel& s = surfels[i];
      if (!(s.confidence >= params.min_confidence)) continue;
      const Vec3f pc = apply(T, s.px, s.py, s.pz);
      if (!(pc.z > params.near_m)) continue;
      const float u = fx * pc.x / pc.z + cx + 0.5f;
      const float v = fy * pc.y / pc.z + cy + 0.5f;
      const float margin = static_cast<float>(params.max_footprint_px) + 1.0f;
      if (!(u >= -margin && v >= -margin && u < static_cast<float>(w) + margin && v < static_cast<float>(h) + margin))
        continue;
      const int pu = static_cast<int>(std::floor(u)), pv = static_cast<int>(std::floor(v));
      const int f = static_cast<int>(
          std::min(static_cast<float>(params.max_footprint_px), std::max(s.radius_m, 0.0f) * fx / pc.z + 0.5f));
      const uint64_t key = (static_cast<uint64_t>(float_bits(pc.z)) << 32) | (base + i);
      for (int y = std::max(pv - f, 0); y <= std::min(pv + f, h - 1); ++y)
        for (int x = std::max(pu - f, 0); x <= std::min(pu + f, w - 1); ++x) {
          uint64_t& g = grid[static_cast<size_t>(y) * w + x];
          g = std::min(g, key);
        }
    }
    base += static_cast<uint32_t>(surfels.size());
  }

  Image out(w, h, params.background_rgba8);
  for (size_t p = 0; p < grid.size(); ++p) {
    if (grid[p] == empty) continue;
    const uint32_t index = static_cast<uint32_t>(grid[p] & 0xFFFFFFFFu);
    size_t m = clouds.size() - 1;
    while (index < bases[m]) --m;
    const Surfel& s = clouds[m].surfels[index - bases[m]];
    const float* T = T_view_model[m].data();
    const Vec3f pc = apply(T, s.px, s.py, s.pz);
    const Vec3f nc = rotate(T, s.nx, s.ny, s.nz);
    using glm::vec3;
    out.rgba[p] = view_shading::view_pack_rgb(view_shading::view_shade(
        static_cast<uint32_t>(params.colour_mode), s.colour_rgba8, model_colour(clouds[m].model_id),
        vec3(nc.x, nc.y, nc.z), vec3(pc.x, pc.y, pc.z), s.confidence, params.confidence_max, params.ambient));
  }
  return out;
}

}  // namespace cofusion::renderer
