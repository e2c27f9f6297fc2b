// Buffers read through their uniform texel views (gpu::Buffer::texel_view: RGBA32UI texels, 16
// bytes each) instead of as storage buffers. Lavapipe (Mesa 22.3) loads a storage buffer at
// per-invocation offsets one lane after another, with a bounds check per lane and component,
// but fetches texels with vector gathers: on this machine the hot kernels that gather (surfel
// association, resolve, splatting, cleanup, the ICP reduction) took about 20% less GPU time per
// frame this way. Bit-exact: every value travels as its uint bits. Writes stay storage buffers.
#ifndef COFUSION_TEXEL_ACCESS_GLSL
#define COFUSION_TEXEL_ACCESS_GLSL
// Surfels: three texels each, in the field order of Surfel (shared/host_device.h).
// Position (xyz) and confidence (w).
vec4 surfel_position_confidence(usamplerBuffer t, uint i) { return uintBitsToFloat(texelFetch(t, int(3u * i))); }
// Normal (xyz) and radius (w).
vec4 surfel_normal_radius(usamplerBuffer t, uint i) { return uintBitsToFloat(texelFetch(t, int(3u * i + 1u))); }
// colour_rgba8, created_frame, last_seen_frame, flags.
uvec4 surfel_tail(usamplerBuffer t, uint i) { return texelFetch(t, int(3u * i + 2u)); }
Surfel surfel_at(usamplerBuffer t, uint i) {
  const vec4 a = surfel_position_confidence(t, i), b = surfel_normal_radius(t, i);
  const uvec4 c = surfel_tail(t, i);
  Surfel s;
  s.px = a.x; s.py = a.y; s.pz = a.z; s.confidence = a.w;
  s.nx = b.x; s.ny = b.y; s.nz = b.z; s.radius_m = b.w;
  s.colour_rgba8 = c.x; s.created_frame = int(c.y); s.last_seen_frame = int(c.z); s.flags = c.w;
  return s;
}
// Texel k (0, 1, 2) of surfel s in the layout above, for stores of whole uvec4s (lavapipe stores
// a struct field by field, lane after lane).
uvec4 surfel_texel(Surfel s, uint k) {
  if (k == 0u) return floatBitsToUint(vec4(s.px, s.py, s.pz, s.confidence));
  if (k == 1u) return floatBitsToUint(vec4(s.nx, s.ny, s.nz, s.radius_m));
  return uvec4(s.colour_rgba8, uint(s.created_frame), uint(s.last_seen_frame), s.flags);
}
// Element i of a buffer of vec4s.
vec4 texel_vec4(usamplerBuffer t, uint i) { return uintBitsToFloat(texelFetch(t, int(i))); }
// Element i of a buffer of vec2s.
vec2 texel_vec2(usamplerBuffer t, uint i) {
  const uvec4 v = texelFetch(t, int(i >> 1u));
  return uintBitsToFloat((i & 1u) == 0u ? v.xy : v.zw);
}
// Element i of a buffer of floats.
float texel_float(usamplerBuffer t, uint i) { return uintBitsToFloat(texelFetch(t, int(i >> 2u))[i & 3u]); }
// Element i of a buffer of 64-bit values, as (low word, high word).
uvec2 texel_uint2(usamplerBuffer t, uint i) {
  const uvec4 v = texelFetch(t, int(i >> 1u));
  return (i & 1u) == 0u ? v.xy : v.zw;
}
// Element i of a buffer of uints.
uint texel_uint(usamplerBuffer t, uint i) { return texelFetch(t, int(i >> 2u))[i & 3u]; }
#endif
