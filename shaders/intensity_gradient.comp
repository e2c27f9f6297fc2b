#version 460
// Sobel gradients of intensity, normalised by 1/8 so they are per-pixel derivatives; borders are
// clamped. Used by the photometric term of tracking.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/image_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = GRADIENT_BINDING_INTENSITY) uniform usamplerBuffer intensity;  // texel view of float
layout(std430, binding = GRADIENT_BINDING_GRADIENT) writeonly buffer Gradient { vec2 gradient[]; };
layout(push_constant) uniform Push { GradientParams p; };
float at(ivec2 q) { return texel_float(intensity, pixel_index(uvec2(clamp_pixel(q, p.width, p.height)), p.width)); }
void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy + uvec2(p.x0, p.y0));
  if (px.x >= int(min(p.x1, p.width)) || px.y >= int(min(p.y1, p.height))) return;
  float tl = at(px + ivec2(-1, -1)), t = at(px + ivec2(0, -1)), tr = at(px + ivec2(1, -1));
  float l = at(px + ivec2(-1, 0)), r = at(px + ivec2(1, 0));
  float bl = at(px + ivec2(-1, 1)), b = at(px + ivec2(0, 1)), br = at(px + ivec2(1, 1));
  float gx = ((tr + 2.0 * r + br) - (tl + 2.0 * l + bl)) * 0.125;
  float gy = ((bl + 2.0 * b + br) - (tl + 2.0 * t + tr)) * 0.125;
  gradient[pixel_index(uvec2(px), p.width)] = vec2(gx, gy);
}
