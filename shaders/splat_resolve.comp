#version 460
// Turns the per-pixel winning surfel into the predicted vertex, normal, intensity and index
// maps in the camera frame. The vertex is where the pixel's ray meets the surfel's disc plane, so
// neighbouring pixels covered by one surfel get distinct points on its plane.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "shared/host_device.h"
#include "shared/rigid.glsl"
#include "shared/texel_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = RESOLVE_BINDING_SURFELS) uniform usamplerBuffer surfels;  // texel view
layout(binding = RESOLVE_BINDING_DEPTH_INDEX) uniform usamplerBuffer depth_index;  // texel view of uint64 keys
layout(std430, binding = RESOLVE_BINDING_VERTEX) writeonly buffer Vertex { vec4 vertex[]; };
layout(std430, binding = RESOLVE_BINDING_NORMAL) writeonly buffer Normal { vec4 normal[]; };
layout(std430, binding = RESOLVE_BINDING_INTENSITY) writeonly buffer Intensity { float intensity[]; };
layout(std430, binding = RESOLVE_BINDING_INDEX) writeonly buffer Index { uint index_map[]; };
layout(push_constant) uniform Push { ResolveParams p; };
void main() {
  uvec2 px = gl_GlobalInvocationID.xy + uvec2(p.x0, p.y0);
  if (px.x >= min(p.x1, p.width) || px.y >= min(p.y1, p.height)) return;
  uint i = px.y * p.width + px.x;
  bool in_area = px.x >= p.area_x0 && px.x < p.area_x1 && px.y >= p.area_y0 && px.y < p.area_y1;
  // Outside the area the key is not read: only the area's rows were cleared before the splat.
  uint64_t key = in_area ? packUint2x32(texel_uint2(depth_index, i)) : ~uint64_t(0);
  if (key == ~uint64_t(0)) {
    vertex[i] = vec4(0.0);
    normal[i] = vec4(0.0);
    intensity[i] = 0.0;
    index_map[i] = 0xFFFFFFFFu;
    return;
  }
  uint si = uint(key & 0xFFFFFFFFul);
  Surfel s = surfel_at(surfels, si);
  vec3 pc = rigid_apply(p.T_camera_model, vec3(s.px, s.py, s.pz));
  vec3 nc = rigid_rotate(p.T_camera_model, vec3(s.nx, s.ny, s.nz));
  vec3 ray = vec3((float(px.x) - p.cx) / p.fx, (float(px.y) - p.cy) / p.fy, 1.0);
  float denom = dot(nc, ray);
  vec3 v = pc;
  if (abs(denom) > 0.2 * length(ray)) {
    float t = dot(nc, pc) / denom;
    if (t > 0.0 && abs(t - pc.z) < 2.0 * s.radius_m + 0.01) v = ray * t;
  }
  vec3 c = unpack_rgb(s.colour_rgba8);
  vertex[i] = vec4(v, 1.0);
  normal[i] = vec4(nc, 1.0);
  intensity[i] = (c.r + c.g + c.b) / 3.0;
  index_map[i] = si;
}
