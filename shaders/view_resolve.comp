#version 460
// Viewer: colours the pixels whose nearest surfel (from view_splat.comp) belongs to this model;
// other pixels are left as they are (background or another model's colour).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/rigid.glsl"
#include "shared/view_shading.h"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = VIEW_RESOLVE_BINDING_SURFELS) uniform usamplerBuffer surfels;  // texel view
layout(binding = VIEW_RESOLVE_BINDING_DEPTH_INDEX) uniform usamplerBuffer depth_index;  // texel view of uint64 keys
layout(std430, binding = VIEW_RESOLVE_BINDING_IMAGE) buffer Image { uint image[]; };
layout(push_constant) uniform Push { ViewResolveParams p; };
void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.width || px.y >= p.height) return;
  uint i = px.y * p.width + px.x;
  uint64_t key = packUint2x32(texel_uint2(depth_index, i));
  if (key == ~uint64_t(0)) return;
  uint index = uint(key & 0xFFFFFFFFul);
  if (index < p.index_base || index - p.index_base >= p.surfel_count) return;
  Surfel s = surfel_at(surfels, index - p.index_base);
  vec3 pc = rigid_apply(p.T_view_model, vec3(s.px, s.py, s.pz));
  vec3 nc = rigid_rotate(p.T_view_model, vec3(s.nx, s.ny, s.nz));
  image[i] = view_pack_rgb(view_shade(p.colour_mode, s.colour_rgba8, p.label_rgba8, nc, pc, s.confidence,
                                      p.confidence_max, p.ambient));
}
