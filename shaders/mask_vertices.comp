#version 460
// A pyramid level's live vertex map restricted to the pixels that the previous segmentation
// labelled as one of the models in keep_mask (Co-Fusion: each model is tracked with its own
// points only). The label map stays at level 0; level pixel (x, y) reads level-0 pixel
// (x << level, y << level), the pixel the pyramid subsampled it from.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = MASK_VERTICES_BINDING_SRC) uniform usamplerBuffer src;  // texel view of vec4
layout(std430, binding = MASK_VERTICES_BINDING_DST) writeonly buffer Dst { vec4 dst[]; };
layout(binding = MASK_VERTICES_BINDING_LABELS) uniform usamplerBuffer labels;  // texel view of uint
layout(push_constant) uniform Push { MaskVerticesParams p; };
void main() {
  uvec2 px = gl_GlobalInvocationID.xy + uvec2(p.rect_x0, p.rect_y0);
  if (px.x >= min(p.rect_x1, p.width) || px.y >= min(p.rect_y1, p.height)) return;
  uint i = px.y * p.width + px.x;
  uvec2 l0 = min(px << p.level, uvec2(p.level0_width - 1u, p.level0_height - 1u));
  uint label = texel_uint(labels, l0.y * p.level0_width + l0.x);
  bool keep = label < MASK_VERTICES_NO_LABEL && ((p.keep_mask >> label) & 1u) != 0u;
  dst[i] = keep ? texel_vec4(src, i) : vec4(0.0);
}
