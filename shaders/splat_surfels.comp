#version 460
// Projects a model's surfels into a view and keeps, per grid cell, the nearest one: a 64-bit
// atomicMin of (depth bits << 32 | surfel index). Positive floats order like their bit patterns,
// so the minimum key is the nearest surfel (ties: the lowest index). The depth is the cell's ray
// on the surfel's plane plus a penalty growing with the cell's distance from the surfel's centre. A compute scatter, because
// drawing points through the graphics pipeline is 20-80x slower on lavapipe.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#include "shared/host_device.h"
#include "shared/rigid.glsl"
#include "shared/texel_access.glsl"
layout(local_size_x = 128) in;
layout(binding = SPLAT_BINDING_SURFELS) uniform usamplerBuffer surfels;  // texel view
layout(std430, binding = SPLAT_BINDING_DEPTH_INDEX) buffer DepthIndex { uint64_t depth_index[]; };
layout(push_constant) uniform Push { SplatParams p; };
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= p.surfel_count) return;
  const vec4 pos_conf = surfel_position_confidence(surfels, i);
  if (pos_conf.w < p.min_confidence && p.frame - int(surfel_tail(surfels, i).y) >= p.recent_window_frames) return;
  vec3 pc = rigid_apply(p.T_camera_model, pos_conf.xyz);
  if (pc.z <= 1e-3) return;
  const vec4 normal_radius = surfel_normal_radius(surfels, i);
  vec3 nc = rigid_rotate(p.T_camera_model, normal_radius.xyz);
  if (dot(nc, pc) > 0.0) return;  // seen from behind
  float scale = float(p.grid_scale);
  // Pixel x of the full-resolution image covers [x - 0.5, x + 0.5); grid cell j covers [j, j+1).
  float u = (p.fx * pc.x / pc.z + p.cx + 0.5) * scale;
  float v = (p.fy * pc.y / pc.z + p.cy + 0.5) * scale;
  if (u < -1.0 || v < -1.0 || u > float(p.width) + 1.0 || v > float(p.height) + 1.0) return;
  int cx = int(floor(u)), cy = int(floor(v));
  int f = min(int(p.footprint_px), int(normal_radius.w * p.fx / pc.z * scale));
  // Keyed by the surfel centre's depth, every cell of the footprint would go to the surfel nearest
  // the camera: on a slanted surface the predicted colours shift towards the near side by up to
  // the footprint, which biases photometric tracking (5 mm on a static synthetic table).
  // A cell's ray, offset (du, dv) cells from the surfel's projection, is pc / pc.z + (du / (scale
  // fx), dv / (scale fy), 0): it meets the plane dot(nc, X) = dot(nc, pc) at depth
  // dot(nc, pc) / (dot(nc, pc) / pc.z + a du + b dv). At grazing angles (tested once, at the
  // centre) the centre's depth is kept.
  float plane_offset = dot(nc, pc);
  bool grazing = abs(plane_offset) <= 0.2 * length(pc);
  float denom0 = plane_offset / pc.z, a = nc.x / (scale * p.fx), b = nc.y / (scale * p.fy);
  float max_dz = 2.0 * normal_radius.w + 0.01;
  float penalty = p.offset_penalty_rel * pc.z / (scale * scale);
  for (int dy = -f; dy <= f; ++dy) {
    for (int dx = -f; dx <= f; ++dx) {
      int x = cx + dx, y = cy + dy;
      if (x < 0 || y < 0 || x >= int(p.width) || y >= int(p.height)) continue;
      float du = float(x) + 0.5 - u, dv = float(y) + 0.5 - v;
      float z = pc.z;
      if (!grazing) {
        float t = plane_offset / (denom0 + a * du + b * dv);
        if (t > 0.0 && abs(t - pc.z) < max_dz) z = t;
      }
      z += penalty * (du * du + dv * dv);
      uint64_t key = (uint64_t(floatBitsToUint(z)) << 32) | uint64_t(i);
      atomicMin(depth_index[uint(y) * p.width + uint(x)], key);
    }
  }
}
