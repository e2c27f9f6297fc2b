#version 460
// Fuses each live pixel into the surfel it claimed (weighted running average of position, normal,
// colour and radius; confidence grows by the measurement weight), or appends a new surfel where
// no surfel explains the pixel. The host guarantees room for one new surfel per pixel.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/rigid.glsl"
#include "shared/fusion.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(std430, binding = FUSE_BINDING_SURFELS) buffer Surfels { Surfel surfels[]; };
layout(std430, binding = FUSE_BINDING_INDEX_MAP) readonly buffer IndexMap { uint index_map_unused[]; };
layout(std430, binding = FUSE_BINDING_VERTEX) readonly buffer Vertex { vec4 vertex[]; };
layout(std430, binding = FUSE_BINDING_NORMAL) readonly buffer Normal { vec4 normal[]; };
layout(std430, binding = FUSE_BINDING_RGB) readonly buffer Rgb { uint rgb[]; };
layout(std430, binding = FUSE_BINDING_ASSOC) readonly buffer Assoc { uint assoc[]; };
layout(std430, binding = FUSE_BINDING_CLAIM) readonly buffer Claim { uint claim[]; };
layout(std430, binding = FUSE_BINDING_COUNTER) buffer Counter { uint counter[]; };
layout(std430, binding = FUSE_BINDING_LABELS) readonly buffer Labels { uint labels_unused[]; };
layout(push_constant) uniform Push { FuseParams p; };
uint byte_at(uint b) { return (rgb[b >> 2] >> ((b & 3u) * 8u)) & 0xFFu; }
void main() {
  uvec2 px = gl_GlobalInvocationID.xy + uvec2(p.rect_x0, p.rect_y0);
  if (px.x >= min(p.rect_x1, p.width) || px.y >= min(p.rect_y1, p.height)) return;
  uint i = px.y * p.width + px.x;
  uint a = assoc[i];
  if (a == FUSE_SKIP_PIXEL) return;
  vec3 v = vertex[i].xyz, n = normal[i].xyz;
  float alpha = measurement_weight(px, p.cx, p.cy);
  float radius = surfel_radius(v, n, p.fx);
  vec3 colour = vec3(byte_at(3u * i), byte_at(3u * i + 1u), byte_at(3u * i + 2u));
  vec3 v_model = rigid_apply_inverse(p.T_camera_model, v);
  vec3 n_model = rigid_rotate_inverse(p.T_camera_model, n);
  if (a == FUSE_NO_SURFEL) {
    uint slot = atomicAdd(counter[0], 1u);
    if (slot >= p.capacity) return;  // cannot happen: the host reserves width*height slots
    Surfel s;
    s.px = v_model.x; s.py = v_model.y; s.pz = v_model.z;
    s.confidence = alpha;
    s.nx = n_model.x; s.ny = n_model.y; s.nz = n_model.z;
    s.radius_m = radius;
    s.colour_rgba8 = pack_rgb(colour);
    s.created_frame = p.frame;
    s.last_seen_frame = p.frame;
    s.flags = 0u;
    surfels[slot] = s;
    return;
  }
  if (claim[a] != i) return;  // another pixel fuses into this surfel
  Surfel s = surfels[a];
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
  surfels[a] = s;
}
