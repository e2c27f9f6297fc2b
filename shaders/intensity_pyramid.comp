#version 460
// Halves an intensity image by averaging each 2x2 source block (clamped at odd borders).
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/image_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = DOWNSAMPLE_BINDING_SRC) uniform usamplerBuffer src;  // texel view of float
layout(std430, binding = DOWNSAMPLE_BINDING_DST) writeonly buffer Dst { float dst[]; };
layout(push_constant) uniform Push { DownsampleParams p; };
void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.dst_width || px.y >= p.dst_height) return;
  uint x_end = min(2u * px.x + 1u, p.src_width - 1u), y_end = min(2u * px.y + 1u, p.src_height - 1u);
  float sum = 0.0, count = 0.0;
  for (uint y = 2u * px.y; y <= y_end; ++y) {
    for (uint x = 2u * px.x; x <= x_end; ++x) {
      sum += texel_float(src, pixel_index(uvec2(x, y), p.src_width));
      count += 1.0;
    }
  }
  dst[pixel_index(px, p.dst_width)] = sum / count;
}
