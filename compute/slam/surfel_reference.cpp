#include "slam/surfel_reference.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace cofusion::slam::reference {
namespace {
using glm::vec3;
constexpr uint64_t kEmpty = ~uint64_t{0};

vec3 rotate(const float* T, vec3 v) {
  return vec3(T[0] * v.x + T[1] * v.y + T[2] * v.z, T[4] * v.x + T[5] * v.y + T[6] * v.z,
              T[8] * v.x + T[9] * v.y + T[10] * v.z);
}
vec3 apply(const float* T, vec3 p) { return rotate(T, p) + vec3(T[3], T[7], T[11]); }
vec3 apply_inverse(const float* T, vec3 p) {
  const vec3 q = p - vec3(T[3], T[7], T[11]);
  return vec3(T[0] * q.x + T[4] * q.y + T[8] * q.z, T[1] * q.x + T[5] * q.y + T[9] * q.z,
              T[2] * q.x + T[6] * q.y + T[10] * q.z);
}
vec3 rotate_inverse(const float* T, vec3 v) {
  return vec3(T[0] * v.x + T[4] * v.y + T[8] * v.z, T[1] * v.x + T[5] * v.y + T[9] * v.z,
              T[2] * v.x + T[6] * v.y + T[10] * v.z);
}
vec3 position(const Surfel& s) { return vec3(s.px, s.py, s.pz); }
vec3 normal_of(const Surfel& s) { return vec3(s.nx, s.ny, s.nz); }
vec3 unpack_rgb(uint32_t c) { return vec3(float(c & 0xFF), float((c >> 8) & 0xFF), float((c >> 16) & 0xFF)); }
uint32_t pack_rgb(vec3 c) {
  const auto b = [](float x) { return static_cast<uint32_t>(std::clamp(std::round(x), 0.0f, 255.0f)); };
  return b(c.r) | (b(c.g) << 8) | (b(c.b) << 16) | (255u << 24);
}
float measurement_weight(int x, int y, float cx, float cy) {
  const float gamma = glm::length(glm::vec2(float(x) - cx, float(y) - cy)) / glm::length(glm::vec2(cx, cy));
  return std::exp(-gamma * gamma / (2.0f * 0.36f));
}
float surfel_radius(vec3 v, vec3 n, float f) {
  const float cos_angle = std::abs(glm::dot(n, glm::normalize(v)));
  return 1.41421356f * v.z / f / std::max(cos_angle, 0.3f);
}
}  // namespace

std::vector<uint64_t> splat(const std::vector<Surfel>& surfels, const gpu_layout::SplatParams& p) {
  std::vector<uint64_t> grid(size_t(p.width) * p.height, kEmpty);
  for (uint32_t i = 0; i < p.surfel_count && i < surfels.size(); ++i) {
    const Surfel& s = surfels[i];
    if (s.confidence < p.min_confidence && p.frame - s.created_frame >= p.recent_window_frames) continue;
    const vec3 pc = apply(p.T_camera_model, position(s));
    if (pc.z <= 1e-3f) continue;
    const vec3 nc = rotate(p.T_camera_model, normal_of(s));
    if (glm::dot(nc, pc) > 0.0f) continue;
    const float scale = float(p.grid_scale);
    const float u = (p.fx * pc.x / pc.z + p.cx + 0.5f) * scale, v = (p.fy * pc.y / pc.z + p.cy + 0.5f) * scale;
    if (u < -1.0f || v < -1.0f || u > float(p.width) + 1.0f || v > float(p.height) + 1.0f) continue;
    const int cx = int(std::floor(u)), cy = int(std::floor(v));
    const int f = std::min(int(p.footprint_px), int(s.radius_m * p.fx / pc.z * scale));
    const float plane_offset = glm::dot(nc, pc);
    const bool grazing = std::abs(plane_offset) <= 0.2f * glm::length(pc);
    const float denom0 = plane_offset / pc.z, a = nc.x / (scale * p.fx), b = nc.y / (scale * p.fy);
    const float max_dz = 2.0f * s.radius_m + 0.01f;
    const float penalty = p.offset_penalty_rel * pc.z / (scale * scale);
    for (int dy = -f; dy <= f; ++dy)
      for (int dx = -f; dx <= f; ++dx) {
        const int x = cx + dx, y = cy + dy;
        if (x < 0 || y < 0 || x >= int(p.width) || y >= int(p.height)) continue;
        const float du = float(x) + 0.5f - u, dv = float(y) + 0.5f - v;
        float z = pc.z;
        if (!grazing) {
          const float t = plane_offset / (denom0 + a * du + b * dv);
          if (t > 0.0f && std::abs(t - pc.z) < max_dz) z = t;
        }
        z += penalty * (du * du + dv * dv);
        const uint64_t key = (uint64_t(std::bit_cast<uint32_t>(z)) << 32) | i;
        uint64_t& cell = grid[size_t(y) * p.width + x];
        cell = std::min(cell, key);
      }
  }
  return grid;
}

PredictedMaps resolve(const std::vector<Surfel>& surfels, const std::vector<uint64_t>& depth_index,
                      const gpu_layout::ResolveParams& p) {
  const int w = int(p.width), h = int(p.height);
  PredictedMaps m{Image<glm::vec4>(w, h), Image<glm::vec4>(w, h), Image<float>(w, h), Image<uint32_t>(w, h, 0xFFFFFFFFu)};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x < int(p.area_x0) || x >= int(p.area_x1) || y < int(p.area_y0) || y >= int(p.area_y1)) continue;
      const uint64_t key = depth_index[size_t(y) * w + x];
      if (key == kEmpty) continue;
      const uint32_t si = uint32_t(key & 0xFFFFFFFFu);
      const Surfel& s = surfels[si];
      const vec3 pc = apply(p.T_camera_model, position(s)), nc = rotate(p.T_camera_model, normal_of(s));
      const vec3 ray((float(x) - p.cx) / p.fx, (float(y) - p.cy) / p.fy, 1.0f);
      const float denom = glm::dot(nc, ray);
      vec3 v = pc;
      if (std::abs(denom) > 0.2f * glm::length(ray)) {
        const float t = glm::dot(nc, pc) / denom;
        if (t > 0.0f && std::abs(t - pc.z) < 2.0f * s.radius_m + 0.01f) v = ray * t;
      }
      const vec3 c = unpack_rgb(s.colour_rgba8);
      m.vertex.at(x, y) = glm::vec4(v, 1.0f);
      m.normal.at(x, y) = glm::vec4(nc, 1.0f);
      m.intensity.at(x, y) = (c.r + c.g + c.b) / 3.0f;
      m.index.at(x, y) = si;
    }
  return m;
}

PredictedMaps subsample(const PredictedMaps& src) {
  const int w = kernels::half_size(src.vertex.width), h = kernels::half_size(src.vertex.height);
  PredictedMaps d{Image<glm::vec4>(w, h), Image<glm::vec4>(w, h), Image<float>(w, h), Image<uint32_t>()};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int sx = std::min(2 * x, src.vertex.width - 1), sy = std::min(2 * y, src.vertex.height - 1);
      d.vertex.at(x, y) = src.vertex.at(sx, sy);
      d.normal.at(x, y) = src.normal.at(sx, sy);
      d.intensity.at(x, y) = src.intensity.at(sx, sy);
    }
  return d;
}

namespace {
bool depth_agrees_around(const std::vector<Surfel>& surfels, const std::vector<uint64_t>& index_map, uint32_t px,
                         uint32_t py, float z_live, const gpu_layout::FuseParams& p) {
  const int S = int(p.grid_scale), c = int(p.new_surfel_clearance_cells);
  const int grid_width = int(p.width) * S, grid_height = int(p.height) * S;
  const int x0 = int(px) * S, y0 = int(py) * S;
  for (int y = std::max(y0 - c, 0); y <= std::min(y0 + S - 1 + c, grid_height - 1); ++y)
    for (int x = std::max(x0 - c, 0); x <= std::min(x0 + S - 1 + c, grid_width - 1); ++x) {
      if (x >= x0 && x < x0 + S && y >= y0 && y < y0 + S) continue;
      const uint64_t key = index_map[size_t(y) * size_t(grid_width) + size_t(x)];
      if (key == kEmpty) continue;
      const float z = apply(p.T_camera_model, position(surfels[uint32_t(key & 0xFFFFFFFFu)])).z;
      if (std::abs(z - z_live) <= p.max_depth_diff_rel * z_live + 0.005f) return true;
    }
  return false;
}
}  // namespace

Association associate(const std::vector<Surfel>& surfels, const std::vector<uint64_t>& index_map, const LiveMaps& live,
                      const gpu_layout::FuseParams& p) {
  Association a{std::vector<uint32_t>(size_t(p.width) * p.height, FUSE_SKIP_PIXEL),
                std::vector<uint32_t>(surfels.size(), 0xFFFFFFFFu)};
  const uint32_t S = p.grid_scale, grid_width = p.width * S;
  for (uint32_t y = p.rect_y0; y < std::min(p.rect_y1, p.height); ++y)
    for (uint32_t x = p.rect_x0; x < std::min(p.rect_x1, p.width); ++x) {
      const uint32_t i = y * p.width + x;
      const glm::vec4 v = live.vertex.pixels[i], n = live.normal.pixels[i];
      if (v.w == 0.0f || n.w == 0.0f || (p.label_mask != FUSE_ALL_LABELS && !LABEL_IN_MASK(live.labels[i], p.label_mask))) continue;
      const vec3 ray = glm::normalize(vec3(v));
      uint32_t best = FUSE_NO_SURFEL;
      float best_confidence = -1.0f, best_ray_dist = 1e30f;
      bool depth_agrees = false;
      for (uint32_t sy = 0; sy < S; ++sy)
        for (uint32_t sx = 0; sx < S; ++sx) {
          const uint64_t key = index_map[size_t(y * S + sy) * grid_width + x * S + sx];
          if (key == kEmpty) continue;
          const uint32_t si = uint32_t(key & 0xFFFFFFFFu);
          const Surfel& s = surfels[si];
          const vec3 pc = apply(p.T_camera_model, position(s)), nc = rotate(p.T_camera_model, normal_of(s));
          if (std::abs(pc.z - v.z) > p.max_depth_diff_rel * v.z + 0.005f) continue;
          depth_agrees = true;
          if (glm::dot(nc, vec3(n)) < p.min_normal_dot) continue;
          const float ray_dist = glm::length(glm::cross(pc, ray));
          if (ray_dist < best_ray_dist || (ray_dist == best_ray_dist && s.confidence > best_confidence)) {
            best = si;
            best_confidence = s.confidence;
            best_ray_dist = ray_dist;
          }
        }
      if (best == FUSE_NO_SURFEL && !depth_agrees) depth_agrees = depth_agrees_around(surfels, index_map, x, y, v.z, p);
      a.assoc[i] = (best == FUSE_NO_SURFEL && depth_agrees) ? FUSE_SKIP_PIXEL : best;
      if (best != FUSE_NO_SURFEL) a.claim[best] = std::min(a.claim[best], i);
    }
  return a;
}

void update(std::vector<Surfel>& surfels, const Association& a, const LiveMaps& live, const gpu_layout::FuseParams& p) {
  std::vector<Surfel> appended;
  for (uint32_t y = 0; y < p.height; ++y)
    for (uint32_t x = 0; x < p.width; ++x) {
      const uint32_t i = y * p.width + x;
      const uint32_t ai = a.assoc[i];
      if (ai == FUSE_SKIP_PIXEL) continue;
      const vec3 v = vec3(live.vertex.pixels[i]), n = vec3(live.normal.pixels[i]);
      const float alpha = measurement_weight(int(x), int(y), p.cx, p.cy);
      const float radius = surfel_radius(v, n, p.fx);
      const vec3 colour = p.colour_gain * vec3(live.rgb[3 * i], live.rgb[3 * i + 1], live.rgb[3 * i + 2]);
      const vec3 v_model = apply_inverse(p.T_camera_model, v), n_model = rotate_inverse(p.T_camera_model, n);
      if (ai == FUSE_NO_SURFEL) {
        Surfel s{};
        s.px = v_model.x, s.py = v_model.y, s.pz = v_model.z;
        s.confidence = alpha;
        s.nx = n_model.x, s.ny = n_model.y, s.nz = n_model.z;
        s.radius_m = radius;
        s.colour_rgba8 = pack_rgb(colour);
        s.created_frame = p.frame;
        s.last_seen_frame = p.frame;
        appended.push_back(s);
        continue;
      }
      if (a.claim[ai] != i) continue;
      Surfel& s = surfels[ai];
      const float c = s.confidence;
      if (radius <= p.max_radius_growth * s.radius_m) {
        const float w = 1.0f / (c + alpha);
        const vec3 pos = (c * position(s) + alpha * v_model) * w;
        const vec3 nrm = glm::normalize(c * normal_of(s) + alpha * n_model);
        const vec3 col = (c * unpack_rgb(s.colour_rgba8) + alpha * colour) * w;
        s.px = pos.x, s.py = pos.y, s.pz = pos.z;
        s.nx = nrm.x, s.ny = nrm.y, s.nz = nrm.z;
        s.colour_rgba8 = pack_rgb(col);
        s.radius_m = (c * s.radius_m + alpha * radius) * w;
      }
      s.confidence = c + alpha;
      s.last_seen_frame = p.frame;
    }
  surfels.insert(surfels.end(), appended.begin(), appended.end());
}

namespace {
bool cell_fused(int x, int y, const std::vector<uint32_t>& labels, const gpu_layout::MergeParams& p) {
  const uint32_t px = uint32_t(x) / p.grid_scale, py = uint32_t(y) / p.grid_scale;
  if (px < p.rect_x0 || px >= std::min(p.rect_x1, p.width) || py < p.rect_y0 || py >= std::min(p.rect_y1, p.height))
    return false;
  return !p.use_labels || LABEL_IN_MASK(labels.at(size_t(py) * p.width + px), p.label_mask);
}

uint32_t merge_target(const std::vector<Surfel>& surfels, const std::vector<uint64_t>& index_map,
                      const std::vector<uint32_t>& labels, uint32_t i, const gpu_layout::MergeParams& p) {
  const Surfel& si = surfels[i];
  if (!(si.confidence < p.max_source_confidence)) return MERGE_NONE;
  const vec3 pc = apply(p.T_camera_model, position(si));
  if (pc.z <= 1e-3f) return MERGE_NONE;
  const uint32_t S = p.grid_scale, grid_width = p.width * S, grid_height = p.height * S;
  const float u = (p.fx * pc.x / pc.z + p.cx + 0.5f) * float(S), v = (p.fy * pc.y / pc.z + p.cy + 0.5f) * float(S);
  const float reach = float(p.window_cells) + 1.0f;
  if (!(u > -reach && v > -reach && u < float(grid_width) + reach && v < float(grid_height) + reach)) return MERGE_NONE;
  const int cx = int(std::floor(u)), cy = int(std::floor(v)), R = int(p.window_cells);
  uint32_t best = MERGE_NONE, last = MERGE_NONE;  // last: the surfel of the cell looked at before (mostly the same)
  float best_d2 = 1e30f;
  const int step = int(std::max(p.window_step, 1u));
  for (int y = cy - R; y <= cy + R; y += step) {
    if (y < 0 || y >= int(grid_height)) continue;
    for (int x = cx - R; x <= cx + R; x += step) {
      if (x < 0 || x >= int(grid_width) || !cell_fused(x, y, labels, p)) continue;
      const uint32_t j = uint32_t(index_map[size_t(y) * grid_width + size_t(x)] & 0xFFFFFFFFu);
      if (j == 0xFFFFFFFFu || j == i || j == last) continue;
      last = j;
      const Surfel& sj = surfels[j];
      if (!(sj.confidence > si.confidence || (sj.confidence == si.confidence && j < i))) continue;
      const vec3 d = position(sj) - position(si);
      const float d2 = glm::dot(d, d), r = p.distance_rel * std::max(si.radius_m, sj.radius_m);
      if (d2 >= r * r || glm::dot(normal_of(si), normal_of(sj)) < p.min_normal_dot) continue;
      if (d2 < best_d2 || (d2 == best_d2 && j < best)) best = j, best_d2 = d2;
    }
  }
  return best;
}
}  // namespace

std::vector<uint32_t> merge_select(const std::vector<Surfel>& surfels, const std::vector<uint64_t>& index_map,
                                   const std::vector<uint32_t>& labels, const gpu_layout::MergeParams& p) {
  const size_t n = std::min(surfels.size(), size_t(p.surfel_count));
  std::vector<uint32_t> target(n, MERGE_NONE);
  for (uint32_t i = 0; i < n; ++i) target[i] = merge_target(surfels, index_map, labels, i, p);
  return target;
}

std::vector<uint32_t> merge_claim(const std::vector<uint32_t>& target) {
  std::vector<uint32_t> claim(target.size(), MERGE_NONE);
  for (uint32_t i = 0; i < target.size(); ++i) {
    const uint32_t t = target[i];
    if (t != MERGE_NONE && target[t] == MERGE_NONE) claim[t] = std::min(claim[t], i);
  }
  return claim;
}

Surfel merge_surfels(const Surfel& kept, const Surfel& merged) {
  const float ca = kept.confidence, cb = merged.confidence;
  const float w = 1.0f / std::max(ca + cb, 1e-20f);
  const vec3 pos = (ca * position(kept) + cb * position(merged)) * w;
  const vec3 nrm = glm::normalize(ca * normal_of(kept) + cb * normal_of(merged));
  const vec3 col = (ca * unpack_rgb(kept.colour_rgba8) + cb * unpack_rgb(merged.colour_rgba8)) * w;
  Surfel s = kept;
  s.px = pos.x, s.py = pos.y, s.pz = pos.z;
  s.nx = nrm.x, s.ny = nrm.y, s.nz = nrm.z;
  s.colour_rgba8 = pack_rgb(col);
  s.radius_m = (ca * kept.radius_m + cb * merged.radius_m) * w;
  s.confidence = std::max(ca, cb);
  s.created_frame = std::min(kept.created_frame, merged.created_frame);
  s.last_seen_frame = std::max(kept.last_seen_frame, merged.last_seen_frame);
  return s;
}

std::vector<Surfel> cleanup(const std::vector<Surfel>& surfels, const Image<float>& depth_m,
                            const gpu_layout::CleanupParams& p, const Merges& merges) {
  std::vector<Surfel> kept;
  for (size_t i = 0; i < surfels.size() && i < p.surfel_count; ++i) {
    Surfel s = surfels[i];
    if (p.merge) {
      const uint32_t t = merges.target.at(i);
      if (t != MERGE_NONE && merges.target.at(t) == MERGE_NONE && merges.claim.at(t) == i) continue;
      const uint32_t c = merges.claim.at(i);
      if (c != MERGE_NONE) s = merge_surfels(s, surfels[c]);
    }
    if (s.confidence < p.stable_confidence && p.frame - s.created_frame > p.unstable_window_frames) continue;
    const vec3 pc = apply(p.T_camera_model, position(s));
    if (pc.z > 1e-3f) {
      const int x = int(std::round(p.fx * pc.x / pc.z + p.cx)), y = int(std::round(p.fy * pc.y / pc.z + p.cy));
      if (x >= 0 && y >= 0 && x < int(p.width) && y < int(p.height)) {
        const float d = depth_m.at(x, y);
        if (d > 0.0f && pc.z < d - p.free_space_margin_rel * d) {
          s.confidence -= p.free_space_penalty;
          if (s.confidence <= 0.0f) continue;
        }
      }
    }
    kept.push_back(s);
  }
  return kept;
}

std::vector<Surfel> remove_region(const std::vector<Surfel>& surfels, const Image<float>& depth_m,
                                  const std::vector<uint32_t>& labels, const gpu_layout::RemoveRegionParams& p) {
  std::vector<Surfel> kept;
  for (size_t i = 0; i < surfels.size() && i < p.surfel_count; ++i) {
    const Surfel& s = surfels[i];
    const vec3 pc = apply(p.T_camera_model, position(s));
    if (pc.z > 1e-3f) {
      const float u = p.fx * pc.x / pc.z + p.cx, v = p.fy * pc.y / pc.z + p.cy;
      if (u >= -0.5f && v >= -0.5f && u < float(p.width) - 0.5f && v < float(p.height) - 0.5f) {
        const int x = int(std::floor(u + 0.5f)), y = int(std::floor(v + 0.5f));
        const float d = depth_m.at(x, y);
        if (labels[size_t(y) * p.width + x] == p.label && d > 0.0f && pc.z < d * (1.0f + p.margin_rel)) continue;
      }
    }
    kept.push_back(s);
  }
  return kept;
}

}  // namespace cofusion::slam::reference
