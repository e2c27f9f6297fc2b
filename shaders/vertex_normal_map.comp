#version 460
// Back-projects metric depth into camera-frame vertices and estimates normals from central
// differences (left/right and up/down neighbours): twice the baseline of KinectFusion's forward
// differences, so half the noise, which fusion's and tracking's normal-angle tests need on real
// sensor depth. Normals face the camera. A vertex or normal without support has w = 0.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/image_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = VERTEX_NORMAL_BINDING_DEPTH) uniform usamplerBuffer depth_m;  // texel view of float
layout(std430, binding = VERTEX_NORMAL_BINDING_VERTEX) writeonly buffer Vertex { vec4 vertex[]; };
layout(std430, binding = VERTEX_NORMAL_BINDING_NORMAL) writeonly buffer Normal { vec4 normal[]; };
layout(push_constant) uniform Push { VertexNormalParams p; };
vec3 back_project(uint x, uint y, float d) {
  return vec3((float(x) - p.cx) * d / p.fx, (float(y) - p.cy) * d / p.fy, d);
}
void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.width || px.y >= p.height) return;
  uint i = pixel_index(px, p.width);
  float d = texel_float(depth_m, i);
  if (d <= 0.0) {
    vertex[i] = vec4(0.0);
    normal[i] = vec4(0.0);
    return;
  }
  vec3 v = back_project(px.x, px.y, d);
  vertex[i] = vec4(v, 1.0);
  vec4 n = vec4(0.0);
  if (px.x > 0u && px.y > 0u && px.x + 1u < p.width && px.y + 1u < p.height) {
    float d_left = texel_float(depth_m, i - 1u), d_right = texel_float(depth_m, i + 1u);
    float d_up = texel_float(depth_m, i - p.width), d_down = texel_float(depth_m, i + p.width);
    if (d_left > 0.0 && d_right > 0.0 && d_up > 0.0 && d_down > 0.0) {
      vec3 c = cross(back_project(px.x + 1u, px.y, d_right) - back_project(px.x - 1u, px.y, d_left),
                     back_project(px.x, px.y + 1u, d_down) - back_project(px.x, px.y - 1u, d_up));
      float len = length(c);
      if (len > 0.0) {
        c /= len;
        n = vec4(dot(c, v) > 0.0 ? -c : c, 1.0);
      }
    }
  }
  normal[i] = n;
}
