#version 460
// Predicted maps of the next-coarser level: pixel (x, y) takes level-l pixel (2x, 2y). Averaging
// would blend surfaces across depth edges; the finer level already holds exact surfel samples.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = SUBSAMPLE_BINDING_SRC_VERTEX) uniform usamplerBuffer src_vertex;  // texel view of vec4
layout(binding = SUBSAMPLE_BINDING_SRC_NORMAL) uniform usamplerBuffer src_normal;  // texel view of vec4
layout(binding = SUBSAMPLE_BINDING_SRC_INTENSITY) uniform usamplerBuffer src_intensity;  // texel view of float
layout(std430, binding = SUBSAMPLE_BINDING_DST_VERTEX) writeonly buffer DV { vec4 dst_vertex[]; };
layout(std430, binding = SUBSAMPLE_BINDING_DST_NORMAL) writeonly buffer DN { vec4 dst_normal[]; };
layout(std430, binding = SUBSAMPLE_BINDING_DST_INTENSITY) writeonly buffer DI { float dst_intensity[]; };
layout(push_constant) uniform Push { SubsampleParams p; };
void main() {
  uvec2 px = gl_GlobalInvocationID.xy + uvec2(p.x0, p.y0);
  if (px.x >= min(p.x1, p.dst_width) || px.y >= min(p.y1, p.dst_height)) return;
  uvec2 src = min(2u * px, uvec2(p.src_width - 1u, p.src_height - 1u));
  uint s = src.y * p.src_width + src.x, d = px.y * p.dst_width + px.x;
  dst_vertex[d] = texel_vec4(src_vertex, s);
  dst_normal[d] = texel_vec4(src_normal, s);
  dst_intensity[d] = texel_float(src_intensity, s);
}
