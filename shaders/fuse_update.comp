#version 460
// Fuses each live pixel into the surfel it claimed (weighted running average of position, normal,
// colour and radius; confidence grows by the measurement weight), or adds a new surfel where no
// surfel explains the pixel. One invocation per pixel of the rectangle, row-major: new surfels
// take their slots in pixel order (fuse_count_new and compaction_scan gave each block of pixels
// its first slot). The host guarantees room for one new surfel per pixel.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/rigid.glsl"
#include "shared/fusion.glsl"
#include "shared/compaction.glsl"
#include "shared/fuse_rect.glsl"
layout(local_size_x = COMPACTION_BLOCK) in;
layout(binding = FUSE_BINDING_SURFELS) uniform usamplerBuffer surfels_in;  // texel view
// Surfels as three uvec4s each (texel_access.glsl's layout): a surfel is three whole-vector stores
// (lavapipe stores a struct field by field, lane after lane), bits unchanged.
layout(std430, binding = FUSE_BINDING_SURFELS_OUT) writeonly buffer Surfels { uvec4 surfel_texels[]; };
layout(std430, binding = FUSE_BINDING_INDEX_MAP) readonly buffer IndexMap { uint index_map_unused[]; };
layout(binding = FUSE_BINDING_VERTEX) uniform usamplerBuffer vertex;  // texel view of vec4
layout(binding = FUSE_BINDING_NORMAL) uniform usamplerBuffer normal;  // texel view of vec4
layout(binding = FUSE_BINDING_RGB) uniform usamplerBuffer rgb;  // texel view of uint
layout(binding = FUSE_BINDING_ASSOC) uniform usamplerBuffer assoc;  // texel view of uint
layout(binding = FUSE_BINDING_CLAIM) uniform usamplerBuffer claim;  // texel view of uint
layout(std430, binding = FUSE_BINDING_LABELS) readonly buffer Labels { uint labels_unused[]; };
layout(std430, binding = FUSE_BINDING_BLOCKS) readonly buffer Blocks { uint blocks[]; };
layout(push_constant) uniform Push { FuseParams p; };
uint byte_at(uint b) { return (texel_uint(rgb, b >> 2) >> ((b & 3u) * 8u)) & 0xFFu; }
void store_surfel(uint index, Surfel s) {
  for (uint k = 0u; k < 3u; ++k) surfel_texels[3u * index + k] = surfel_texel(s, k);
}
void main() {
  uvec2 px;
  const bool inside = fuse_rect_pixel(p, gl_GlobalInvocationID.x, px);
  const uint i = px.y * p.width + px.x;
  const uint a = inside ? texel_uint(assoc, i) : FUSE_SKIP_PIXEL;
  uint block_total;
  const uint rank = compaction_rank(a == FUSE_NO_SURFEL, block_total);
  if (a == FUSE_SKIP_PIXEL) return;
  vec3 v = texel_vec4(vertex, i).xyz, n = texel_vec4(normal, i).xyz;
  float alpha = measurement_weight(px, p.cx, p.cy);
  float radius = surfel_radius(v, n, p.fx);
  vec3 colour = p.colour_gain * vec3(byte_at(3u * i), byte_at(3u * i + 1u), byte_at(3u * i + 2u));
  vec3 v_model = rigid_apply_inverse(p.T_camera_model, v);
  vec3 n_model = rigid_rotate_inverse(p.T_camera_model, n);
  if (a == FUSE_NO_SURFEL) {
    const uint slot = blocks[gl_WorkGroupID.x] + rank;
    if (slot >= p.capacity) return;  // cannot happen: the host reserves a slot per pixel
    Surfel s;
    s.px = v_model.x; s.py = v_model.y; s.pz = v_model.z;
    s.confidence = alpha;
    s.nx = n_model.x; s.ny = n_model.y; s.nz = n_model.z;
    s.radius_m = radius;
    s.colour_rgba8 = pack_rgb(colour);
    s.created_frame = p.frame;
    s.last_seen_frame = p.frame;
    s.flags = 0u;
    store_surfel(slot, s);
    return;
  }
  if (texel_uint(claim, a) != i) return;  // another pixel fuses into this surfel
  Surfel s = surfel_at(surfels_in, a);
  float c = s.confidence;
  if (radius <= p.max_radius_growth * s.radius_m) {
    float w = 1.0 / (c + alpha);
    vec3 pos = (c * vec3(s.px, s.py, s.pz) + alpha * v_model) * w;
    vec3 nrm = normalize(c * vec3(s.nx, s.ny, s.nz) + alpha * n_model);
    vec3 col = (c * unpack_rgb(s.colour_rgba8) + alpha * colour) * w;
    s.px = pos.x; s.py = pos.y; s.pz = pos.z;
    s.nx = nrm.x; s.ny = nrm.y; s.nz = nrm.z;
    s.colour_rgba8 = pack_rgb(col);
    s.radius_m = (c * s.radius_m + alpha * radius) * w;
  }
  s.confidence = c + alpha;
  s.last_seen_frame = p.frame;
  store_surfel(a, s);
}
