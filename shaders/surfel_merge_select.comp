#version 460
// Per surfel: the neighbour it should merge into (rule in shared/host_device.h, MergeParams).
// Only this invocation writes target[i]; the choice depends on no other invocation.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/rigid.glsl"
#include "shared/texel_access.glsl"
#include "shared/small_division.glsl"
layout(local_size_x = 128) in;
layout(binding = MERGE_BINDING_SURFELS) uniform usamplerBuffer surfels;  // texel view
layout(binding = MERGE_BINDING_INDEX_MAP) uniform usamplerBuffer index_map;  // texel view of uint64 keys
layout(std430, binding = MERGE_BINDING_TARGET) writeonly buffer Target { uint target[]; };
layout(std430, binding = MERGE_BINDING_CLAIM) readonly buffer Claim { uint claim_unused[]; };
layout(std430, binding = MERGE_BINDING_COUNTER) readonly buffer Counter { uint counter[]; };
layout(binding = MERGE_BINDING_LABELS) uniform usamplerBuffer labels;  // texel view of uint
layout(push_constant) uniform Push { MergeParams p; };

// Whether this fusion covered cell (x, y) of the index map (see MergeParams).
bool cell_fused(int x, int y) {
  const uint px = small_quotient(uint(x), p.grid_scale), py = small_quotient(uint(y), p.grid_scale);
  if (px < p.rect_x0 || px >= min(p.rect_x1, p.width) || py < p.rect_y0 || py >= min(p.rect_y1, p.height)) return false;
  return p.use_labels == 0u || LABEL_IN_MASK(texel_uint(labels, py * p.width + px), p.label_mask);
}

uint merge_target(uint i) {
  const vec4 pos_i = surfel_position_confidence(surfels, i);
  if (!(pos_i.w < p.max_source_confidence)) return MERGE_NONE;
  const vec4 nrm_i = surfel_normal_radius(surfels, i);
  const vec3 pc = rigid_apply(p.T_camera_model, pos_i.xyz);
  if (pc.z <= 1e-3) return MERGE_NONE;
  const uint S = p.grid_scale, grid_width = p.width * S, grid_height = p.height * S;
  const float u = (p.fx * pc.x / pc.z + p.cx + 0.5) * float(S), v = (p.fy * pc.y / pc.z + p.cy + 0.5) * float(S);
  const float reach = float(p.window_cells) + 1.0;
  if (!(u > -reach && v > -reach && u < float(grid_width) + reach && v < float(grid_height) + reach)) return MERGE_NONE;
  const int cx = int(floor(u)), cy = int(floor(v)), R = int(p.window_cells);
  uint best = MERGE_NONE, last = MERGE_NONE;  // last: the surfel of the cell looked at before (mostly the same)
  float best_d2 = 1e30;
  const int step = int(max(p.window_step, 1u));
  for (int y = cy - R; y <= cy + R; y += step) {
    if (y < 0 || y >= int(grid_height)) continue;
    for (int x = cx - R; x <= cx + R; x += step) {
      if (x < 0 || x >= int(grid_width) || !cell_fused(x, y)) continue;
      const uint j = texel_uint(index_map, 2u * (uint(y) * grid_width + uint(x)));
      if (j == 0xFFFFFFFFu || j == i || j == last) continue;
      last = j;
      const vec4 pos_j = surfel_position_confidence(surfels, j);
      if (!(pos_j.w > pos_i.w || (pos_j.w == pos_i.w && j < i))) continue;  // j must be the one kept
      const vec4 nrm_j = surfel_normal_radius(surfels, j);
      const vec3 d = pos_j.xyz - pos_i.xyz;
      const float d2 = dot(d, d), r = p.distance_rel * max(nrm_i.w, nrm_j.w);
      if (d2 >= r * r || dot(nrm_i.xyz, nrm_j.xyz) < p.min_normal_dot) continue;
      if (d2 < best_d2 || (d2 == best_d2 && j < best)) {
        best = j;
        best_d2 = d2;
      }
    }
  }
  return best;
}

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= min(p.surfel_count, counter[0])) return;
  target[i] = merge_target(i);
}
