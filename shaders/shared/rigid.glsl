// Rigid transforms stored row-major as float[12] (3x4) in push constants (GLSL only).
#ifndef COFUSION_RIGID_GLSL
#define COFUSION_RIGID_GLSL
vec3 rigid_rotate(float T[12], vec3 v) {
  return vec3(T[0] * v.x + T[1] * v.y + T[2] * v.z, T[4] * v.x + T[5] * v.y + T[6] * v.z,
              T[8] * v.x + T[9] * v.y + T[10] * v.z);
}
vec3 rigid_apply(float T[12], vec3 p) { return rigid_rotate(T, p) + vec3(T[3], T[7], T[11]); }
// Inverse of a rigid transform applied to p: R^T (p - t).
vec3 rigid_apply_inverse(float T[12], vec3 p) {
  vec3 q = p - vec3(T[3], T[7], T[11]);
  return vec3(T[0] * q.x + T[4] * q.y + T[8] * q.z, T[1] * q.x + T[5] * q.y + T[9] * q.z,
              T[2] * q.x + T[6] * q.y + T[10] * q.z);
}
vec3 rigid_rotate_inverse(float T[12], vec3 v) {
  return vec3(T[0] * v.x + T[4] * v.y + T[8] * v.z, T[1] * v.x + T[5] * v.y + T[9] * v.z,
              T[2] * v.x + T[6] * v.y + T[10] * v.z);
}
vec3 unpack_rgb(uint rgba8) { return vec3(rgba8 & 0xFFu, (rgba8 >> 8) & 0xFFu, (rgba8 >> 16) & 0xFFu); }
uint pack_rgb(vec3 c) {
  uvec3 b = uvec3(clamp(round(c), vec3(0.0), vec3(255.0)));
  return b.r | (b.g << 8) | (b.b << 16) | (255u << 24);
}
#endif
