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
// Adds the sample at `offset` from pixel px (inside the image) to the weighted sums.
void add_sample(ivec2 px, ivec2 offset, float centre, float inv_2ss, float inv_2sd, inout float sum,
                inout float weight_sum) {
  const ivec2 q = px + offset;
  float d = texel_float(src, pixel_index(uvec2(q), p.width));
  if (d <= 0.0) return;
  float dx = float(offset.x), dy = float(offset.y), dd = d - centre;
  float w = exp(-(dx * dx + dy * dy) * inv_2ss - dd * dd * inv_2sd);
  sum += w * d;
  weight_sum += w;
}
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
  const int r = p.radius_px;
  if (r == 1) {
    // The default 3x3 window with constant bounds, which the compiler unrolls (lavapipe runs a
    // loop with per-lane bounds for every lane); the same samples in the same order as below.
    for (int oy = -1; oy <= 1; ++oy)
      for (int ox = -1; ox <= 1; ++ox)
        if (all(greaterThanEqual(px + ivec2(ox, oy), ivec2(0))) && all(lessThan(px + ivec2(ox, oy), ivec2(p.width, p.height))))
          add_sample(px, ivec2(ox, oy), centre, inv_2ss, inv_2sd, sum, weight_sum);
  } else {
    for (int oy = max(-r, -px.y); oy <= min(r, int(p.height) - 1 - px.y); ++oy)
      for (int ox = max(-r, -px.x); ox <= min(r, int(p.width) - 1 - px.x); ++ox)
        add_sample(px, ivec2(ox, oy), centre, inv_2ss, inv_2sd, sum, weight_sum);
  }
  dst[pixel_index(uvec2(px), p.width)] = sum / weight_sum;
}
