#version 460
// 16-bit sensor depth -> metres. Readings outside [min_depth_m, max_depth_m] become 0 (no reading).
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/image_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = DEPTH_TO_METRES_BINDING_RAW) uniform usamplerBuffer raw;  // texel view of uint
layout(std430, binding = DEPTH_TO_METRES_BINDING_DEPTH) writeonly buffer Depth { float depth_m[]; };
layout(push_constant) uniform Push { DepthToMetresParams p; };
void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.width || px.y >= p.height) return;
  uint i = pixel_index(px, p.width);
  uint units = (texel_uint(raw, i >> 1) >> ((i & 1u) * 16u)) & 0xFFFFu;
  float d = float(units) * p.metres_per_unit;
  depth_m[i] = (units == 0u || d < p.min_depth_m || d > p.max_depth_m) ? 0.0 : d;
}
