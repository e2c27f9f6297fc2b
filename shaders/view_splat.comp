#version 460
// Viewer: scatters one model's surfels into the shared depth/index grid with a 64-bit atomicMin
// of (depth bits << 32 | index_base + surfel index); a square of half-size
// min(max_footprint_px, projected radius rounded) per surfel, so that surfels spaced by their
// radius leave no holes. Back faces are drawn too (a free viewpoint
// sees both sides). Reads the model buffer only.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/rigid.glsl"
layout(local_size_x = 128) in;
layout(binding = VIEW_SPLAT_BINDING_SURFELS) uniform usamplerBuffer surfels;  // texel view
layout(std430, binding = VIEW_SPLAT_BINDING_DEPTH_INDEX) buffer DepthIndex { uint64_t depth_index[]; };
layout(push_constant) uniform Push { ViewSplatParams p; };
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= p.surfel_count) return;
  Surfel s = surfel_at(surfels, i);
  if (!(s.confidence >= p.min_confidence)) return;
  vec3 pc = rigid_apply(p.T_view_model, vec3(s.px, s.py, s.pz));
  if (!(pc.z > p.near_m)) return;
  float u = p.fx * pc.x / pc.z + p.cx + 0.5;
  float v = p.fy * pc.y / pc.z + p.cy + 0.5;
  float margin = float(p.max_footprint_px) + 1.0;
  if (!(u >= -margin && v >= -margin && u < float(p.width) + margin && v < float(p.height) + margin)) return;
  int cx = int(floor(u)), cy = int(floor(v));
  int f = int(min(float(p.max_footprint_px), max(s.radius_m, 0.0) * p.fx / pc.z + 0.5));
  uint64_t key = (uint64_t(floatBitsToUint(pc.z)) << 32) | uint64_t(p.index_base + i);
  for (int y = max(cy - f, 0); y <= min(cy + f, int(p.height) - 1); ++y)
    for (int x = max(cx - f, 0); x <= min(cx + f, int(p.width) - 1); ++x)
      atomicMin(depth_index[uint(y) * p.width + uint(x)], key);
}
