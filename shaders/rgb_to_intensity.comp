#version 460
// RGB8 -> intensity I = (r + g + b) / 3 in [0, 255]. The RGB bytes arrive tightly packed
// (3 per pixel) in a uint array, as the frame sources deliver them, to avoid a CPU repack.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/image_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = INTENSITY_BINDING_RGB) uniform usamplerBuffer rgb;  // texel view of uint
layout(std430, binding = INTENSITY_BINDING_INTENSITY) writeonly buffer Intensity { float intensity[]; };
layout(push_constant) uniform Push { IntensityParams p; };
uint byte_at(uint i) { return (texel_uint(rgb, i >> 2) >> ((i & 3u) * 8u)) & 0xFFu; }
void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.width || px.y >= p.height) return;
  uint i = pixel_index(px, p.width);
  uint sum = byte_at(3u * i) + byte_at(3u * i + 1u) + byte_at(3u * i + 2u);
  intensity[i] = float(sum) / 3.0;
}
