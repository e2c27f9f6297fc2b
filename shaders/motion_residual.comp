#version 460
// Per-pixel alignment cost of the live frame against one model's predicted view, after tracking:
// what Co-Fusion's motion segmentation takes as unaries. Association is icp_rgb_reduce.comp's
// (nearest reference pixel of the transformed live point); the layout of the output is described
// in shared/host_device.h. CPU reference: compute/slam/motion_reference.cpp.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(std430, binding = MOTION_RESIDUAL_BINDING_LIVE_VERTEX) readonly buffer LiveVertex { vec4 live_vertex[]; };
layout(std430, binding = MOTION_RESIDUAL_BINDING_LIVE_INTENSITY) readonly buffer LiveIntensity { float live_intensity[]; };
layout(std430, binding = MOTION_RESIDUAL_BINDING_REF_VERTEX) readonly buffer RefVertex { vec4 ref_vertex[]; };
layout(std430, binding = MOTION_RESIDUAL_BINDING_REF_NORMAL) readonly buffer RefNormal { vec4 ref_normal[]; };
layout(std430, binding = MOTION_RESIDUAL_BINDING_REF_INTENSITY) readonly buffer RefIntensity { float ref_intensity[]; };
layout(std430, binding = MOTION_RESIDUAL_BINDING_OUT) writeonly buffer Out { vec4 residual[]; };
layout(push_constant) uniform Push { MotionResidualParams p; };
void main() {
  uvec2 px = gl_GlobalInvocationID.xy + uvec2(p.rect_x0, p.rect_y0);
  if (px.x >= min(p.rect_x1, p.width) || px.y >= min(p.rect_y1, p.height)) return;
  uint i = px.y * p.width + px.x;
  vec4 v_live = live_vertex[i];
  if (v_live.w <= 0.0) {
    residual[i] = vec4(0.0, 0.0, 0.0, MOTION_STATUS_NO_LIVE);
    return;
  }
  // Same arithmetic as icp_rgb_reduce.comp, so both associate the same pixels.
  const mat3 R = mat3(p.T_reference_live[0], p.T_reference_live[4], p.T_reference_live[8],
                      p.T_reference_live[1], p.T_reference_live[5], p.T_reference_live[9],
                      p.T_reference_live[2], p.T_reference_live[6], p.T_reference_live[10]);
  const vec3 t = vec3(p.T_reference_live[3], p.T_reference_live[7], p.T_reference_live[11]);
  const vec3 q = R * v_live.xyz + t;
  const vec4 none = vec4(0.0, 0.0, 0.0, MOTION_STATUS_NO_MODEL);
  if (q.z <= 0.0) {
    residual[i] = none;
    return;
  }
  const float x = p.fx * q.x / q.z + p.cx, y = p.fy * q.y / q.z + p.cy;
  // Float comparisons first: x, y may be far outside int range.
  if (!(x >= -0.5 && y >= -0.5 && x < float(p.width) - 0.5 && y < float(p.height) - 0.5)) {
    residual[i] = none;
    return;
  }
  const uint j = uint(floor(y + 0.5)) * p.width + uint(floor(x + 0.5));
  const vec4 v_ref = ref_vertex[j];
  if (v_ref.w <= 0.0) {
    residual[i] = none;
    return;
  }
  const vec4 n_ref = ref_normal[j];
  const vec3 d = q - v_ref.xyz;
  const float distance_m = n_ref.w > 0.0 ? abs(dot(n_ref.xyz, d)) : length(d);
  const float intensity = abs(ref_intensity[j] - live_intensity[i]) * (1.0 / 255.0);
  residual[i] = vec4(distance_m, q.z - v_ref.z, intensity, MOTION_STATUS_ASSOCIATED);
}
