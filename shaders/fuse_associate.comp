#version 460
// Projective data association for fusion: each live pixel looks at its block of the supersampled
// index map and picks, among the surfels that agree in depth and normal, the one nearest to the
// pixel's ray (ties: the most confident), so that neighbouring pixels keep to their own surfels. Several pixels may pick one surfel; the lowest pixel index
// claims it (atomicMin), so the update is race-free and deterministic.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/rigid.glsl"
#include "shared/texel_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = FUSE_BINDING_SURFELS) uniform usamplerBuffer surfels;  // texel buffer
layout(binding = FUSE_BINDING_INDEX_MAP) uniform usamplerBuffer index_map;  // texel view of uint64 keys
layout(binding = FUSE_BINDING_VERTEX) uniform usamplerBuffer vertex;  // texel view of vec4
layout(binding = FUSE_BINDING_NORMAL) uniform usamplerBuffer normal;  // texel view of vec4
layout(std430, binding = FUSE_BINDING_RGB) readonly buffer Rgb { uint rgb[]; };
layout(std430, binding = FUSE_BINDING_ASSOC) writeonly buffer Assoc { uint assoc[]; };
layout(std430, binding = FUSE_BINDING_CLAIM) buffer Claim { uint claim[]; };
layout(std430, binding = FUSE_BINDING_COUNTER) buffer Counter { uint counter[]; };
layout(binding = FUSE_BINDING_LABELS) uniform usamplerBuffer labels;  // texel view of uint
layout(push_constant) uniform Push { FuseParams p; };
// Whether a surfel in the ring of new_surfel_clearance_cells cells around pixel px's block of the
// index map lies within the association's depth tolerance of z_live.
bool depth_agrees_around(uvec2 px, float z_live) {
  const int S = int(p.grid_scale), c = int(p.new_surfel_clearance_cells);
  const int grid_width = int(p.width) * S, grid_height = int(p.height) * S;
  const int x0 = int(px.x) * S, y0 = int(px.y) * S;
  for (int y = max(y0 - c, 0); y <= min(y0 + S - 1 + c, grid_height - 1); ++y) {
    for (int x = max(x0 - c, 0); x <= min(x0 + S - 1 + c, grid_width - 1); ++x) {
      if (x >= x0 && x < x0 + S && y >= y0 && y < y0 + S) continue;  // the block itself
      const uint si = texel_uint(index_map, 2u * uint(y * grid_width + x));
      if (si == 0xFFFFFFFFu) continue;
      const float z = rigid_apply(p.T_camera_model, surfel_position_confidence(surfels, si).xyz).z;
      if (abs(z - z_live) <= p.max_depth_diff_rel * z_live + 0.005) return true;
    }
  }
  return false;
}
// The association's choice so far among a pixel's cells.
struct Candidate {
  uint best;
  float best_confidence, best_ray_dist;
  bool depth_agrees;
};
// Surfel si (0xFFFFFFFF: an empty cell) as a candidate for the live vertex v with normal n.
void consider(uint si, vec4 v, vec3 n, vec3 ray, inout Candidate c) {
  if (si == 0xFFFFFFFFu) return;
  const vec4 pos_conf = surfel_position_confidence(surfels, si);
  vec3 pc = rigid_apply(p.T_camera_model, pos_conf.xyz);
  vec3 nc = rigid_rotate(p.T_camera_model, surfel_normal_radius(surfels, si).xyz);
  if (abs(pc.z - v.z) > p.max_depth_diff_rel * v.z + 0.005) return;
  c.depth_agrees = true;
  if (dot(nc, n) < p.min_normal_dot) return;
  float ray_dist = length(cross(pc, ray));
  if (ray_dist < c.best_ray_dist || (ray_dist == c.best_ray_dist && pos_conf.w > c.best_confidence)) {
    c.best = si;
    c.best_confidence = pos_conf.w;
    c.best_ray_dist = ray_dist;
  }
}
void main() {
  uvec2 px = gl_GlobalInvocationID.xy + uvec2(p.rect_x0, p.rect_y0);
  if (px.x >= min(p.rect_x1, p.width) || px.y >= min(p.rect_y1, p.height)) return;
  uint i = px.y * p.width + px.x;
  vec4 v = texel_vec4(vertex, i), n = texel_vec4(normal, i);
  if (v.w == 0.0 || n.w == 0.0 || (p.label_mask != FUSE_ALL_LABELS && !LABEL_IN_MASK(texel_uint(labels, i), p.label_mask))) {
    assoc[i] = FUSE_SKIP_PIXEL;
    return;
  }
  vec3 ray = normalize(v.xyz);
  uint S = p.grid_scale, grid_width = p.width * S;
  Candidate c = Candidate(FUSE_NO_SURFEL, -1.0, 1e30, false);
  // One texel holds two neighbouring cells' keys: with an even grid scale each row of the block
  // is one fetch. Only a key's low word (the surfel index) is needed; an empty cell is all ones,
  // and no surfel has index 0xFFFFFFFF.
  if (S == 2u) {
    // The default grid scale with constant bounds, which the compiler unrolls.
    // A surfel mostly holds several cells of the block: each is considered once (considering one
    // again changes nothing, as it neither beats nor ties itself better).
    const uvec4 row0 = texelFetch(index_map, int(((px.y * 2u) * grid_width + px.x * 2u) >> 1u));
    const uvec4 row1 = texelFetch(index_map, int(((px.y * 2u + 1u) * grid_width + px.x * 2u) >> 1u));
    consider(row0.x, v, n.xyz, ray, c);
    if (row0.z != row0.x) consider(row0.z, v, n.xyz, ray, c);
    if (row1.x != row0.x && row1.x != row0.z) consider(row1.x, v, n.xyz, ray, c);
    if (row1.z != row0.x && row1.z != row0.z && row1.z != row1.x) consider(row1.z, v, n.xyz, ray, c);
  } else {
    uint pair_texel = 0xFFFFFFFFu;
    uvec4 pair = uvec4(0u);
    for (uint sy = 0u; sy < S; ++sy) {
      for (uint sx = 0u; sx < S; ++sx) {
        const uint cell = (px.y * S + sy) * grid_width + px.x * S + sx;
        if ((cell >> 1u) != pair_texel) {
          pair_texel = cell >> 1u;
          pair = texelFetch(index_map, int(pair_texel));
        }
        consider((cell & 1u) == 0u ? pair.x : pair.z, v, n.xyz, ray, c);
      }
    }
  }
  uint best = c.best;
  bool depth_agrees = c.depth_agrees;
  // A pixel on a known surface whose normal disagrees (sensor noise) neither updates it nor
  // spawns a duplicate; new surfels come only from surface not yet in the model, nor near a
  // surfel of it (a gap between known surfels is no new surface).
  if (best == FUSE_NO_SURFEL && !depth_agrees) depth_agrees = depth_agrees_around(px, v.z);
  assoc[i] = (best == FUSE_NO_SURFEL && depth_agrees) ? FUSE_SKIP_PIXEL : best;
  if (best != FUSE_NO_SURFEL) atomicMin(claim[best], i);
}
