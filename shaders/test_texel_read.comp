#version 460
// Compute-core test kernel: reads src through its texel view with one of the texel_access.glsl
// helpers and writes every 32-bit word back, so the test can compare bit for bit.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
layout(local_size_x = 64) in;
layout(binding = TEST_TEXEL_BINDING_SRC) uniform usamplerBuffer src;
layout(std430, binding = TEST_TEXEL_BINDING_DST) writeonly buffer Dst { uint dst[]; };
layout(push_constant) uniform Push { TestTexelParams p; };
void main() {
  uint i = gl_GlobalInvocationID.x;  // word index
  if (i >= p.words) return;
  uint w = 0u;
  if (p.mode == 0u) w = texel_uint(src, i);
  else if (p.mode == 1u) w = floatBitsToUint(texel_float(src, i));
  else if (p.mode == 2u) w = floatBitsToUint(texel_vec2(src, i / 2u)[i % 2u]);
  else if (p.mode == 3u) w = floatBitsToUint(texel_vec4(src, i / 4u)[i % 4u]);
  else if (p.mode == 4u) w = texel_uint2(src, i / 2u)[i % 2u];
  else {
    const Surfel s = surfel_at(src, i / 12u);
    const uint f = i % 12u;
    const uint words[12] = uint[12](floatBitsToUint(s.px), floatBitsToUint(s.py), floatBitsToUint(s.pz),
                                    floatBitsToUint(s.confidence), floatBitsToUint(s.nx), floatBitsToUint(s.ny),
                                    floatBitsToUint(s.nz), floatBitsToUint(s.radius_m), s.colour_rgba8,
                                    uint(s.created_frame), uint(s.last_seen_frame), s.flags);
    w = words[f];
  }
  dst[i] = w;
}
