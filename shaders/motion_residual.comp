#version 460
// Per-pixel alignment cost of the live frame against one model's predicted view, after tracking:
// what Co-Fusion's motion segmentation takes as unaries. Association is icp_rgb_reduce.comp's
// (nearest reference pixel of the transformed live point); the layout of the output is described
// in shared/host_device.h. CPU reference: compute/slam/motion_reference.cpp.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
layout(local_size_x = COFUSION_TILE, local_size_y = COFUSION_TILE) in;
layout(binding = MOTION_RESIDUAL_BINDING_LIVE_VERTEX) uniform usamplerBuffer live_vertex;  // texel view of vec4
layout(binding = MOTION_RESIDUAL_BINDING_LIVE_INTENSITY) uniform usamplerBuffer live_intensity;  // texel view of float
layout(binding = MOTION_RESIDUAL_BINDING_REF_VERTEX) uniform usamplerBuffer ref_vertex;  // texel view of vec4
layout(binding = MOTION_RESIDUAL_BINDING_REF_NORMAL) uniform usamplerBuffer ref_normal;  // texel view of vec4
layout(binding = MOTION_RESIDUAL_BINDING_REF_INTENSITY) uniform usamplerBuffer ref_intensity;  // texel view of float
layout(std430, binding = MOTION_RESIDUAL_BINDING_OUT) writeonly buffer Out { vec4 residual[]; };
layout(push_constant) uniform Push { MotionResidualParams p; };
void main() {
  uvec2 px = gl_GlobalInvocationID.xy + uvec2(p.rect_x0, p.rect_y0);
  if (px.x >= min(p.rect_x1, p.width) || px.y >= min(p.rect_y1, p.height)) return;
  uint i = px.y * p.width + px.x;
  vec4 v_live = texel_vec4(live_vertex, i);
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
  const vec4 v_ref = texel_vec4(ref_vertex, j);
  if (v_ref.w <= 0.0) {
    residual[i] = none;
    return;
  }
  const vec4 n_ref = texel_vec4(ref_normal, j);
  const vec3 d = q - v_ref.xyz;
  const float distance_m = n_ref.w > 0.0 ? abs(dot(n_ref.xyz, d)) : length(d);
  const float intensity = abs(texel_float(ref_intensity, j) - p.live_intensity_gain * texel_float(live_intensity, i)) * (1.0 / 255.0);
  residual[i] = vec4(distance_m, q.z - v_ref.z, intensity, MOTION_STATUS_ASSOCIATED);
}
