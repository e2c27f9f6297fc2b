#version 460
// Edge-preserving smoothing of metric depth: weights are a spatial Gaussian times a Gaussian of
// the depth difference to the centre, so samples across a depth edge barely contribute.
// Pixels without a reading stay without one and are never used as samples.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/image_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = BILATERAL_BINDING_SRC) uniform usamplerBuffer src;  // texel view of float
layout(std430, binding = BILATERAL_BINDING_DST) writeonly buffer Dst { float dst[]; };
layout(push_constant) uniform Push { BilateralParams p; };
void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (px.x >= int(p.width) || px.y >= int(p.height)) return;
  float centre = texel_float(src, pixel_index(uvec2(px), p.width));
  if (centre <= 0.0) {
    dst[pixel_index(uvec2(px), p.width)] = 0.0;
    return;
  }
  float inv_2ss = 0.5 / (p.sigma_space_px * p.sigma_space_px);
  float inv_2sd = 0.5 / (p.sigma_depth_m * p.sigma_depth_m);
  float sum = 0.0, weight_sum = 0.0;
  if (p.radius_px == 1) {
    // The default 3x3 window with constant bounds, which the compiler unrolls (lavapipe runs a
    // loop with per-lane bounds for every lane); the same terms in the same order as the loop below.
    for (int oy = -1; oy <= 1; ++oy) {
      for (int ox = -1; ox <= 1; ++ox) {
        const int x = px.x + ox, y = px.y + oy;
        if (x < 0 || y < 0 || x >= int(p.width) || y >= int(p.height)) continue;
        float d = texel_float(src, pixel_index(uvec2(x, y), p.width));
        if (d <= 0.0) continue;
        float dx = float(ox), dy = float(oy), dd = d - centre;
        float w = exp(-(dx * dx + dy * dy) * inv_2ss - dd * dd * inv_2sd);
        sum += w * d;
        weight_sum += w;
      }
    }
    dst[pixel_index(uvec2(px), p.width)] = sum / weight_sum;
    return;
  }
  int x0 = max(px.x - p.radius_px, 0), x1 = min(px.x + p.radius_px, int(p.width) - 1);
  int y0 = max(px.y - p.radius_px, 0), y1 = min(px.y + p.radius_px, int(p.height) - 1);
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      float d = texel_float(src, pixel_index(uvec2(x, y), p.width));
      if (d <= 0.0) continue;
      float dx = float(x - px.x), dy = float(y - px.y), dd = d - centre;
      float w = exp(-(dx * dx + dy * dy) * inv_2ss - dd * dd * inv_2sd);
      sum += w * d;
      weight_sum += w;
    }
  }
  dst[pixel_index(uvec2(px), p.width)] = sum / weight_sum;
}
