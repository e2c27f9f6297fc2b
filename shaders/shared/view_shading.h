// Per-pixel shading of the viewer (renderer/), written once for GLSL (view_resolve.comp) and C++
// (the CPU reference in renderer/view_reference.cpp) so both compute the same colours.
// C++ side: glm supplies vec3 and the GLSL built-ins.
#ifndef COFUSION_VIEW_SHADING_H
#define COFUSION_VIEW_SHADING_H

#include "shared/host_device.h"

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace cofusion::view_shading {
using glm::abs;
using glm::clamp;
using glm::dot;
using glm::floor;
using glm::length;
using glm::max;
using glm::min;
using glm::vec3;
using uint = std::uint32_t;
#define COFUSION_VS_FN inline
#else
#define COFUSION_VS_FN
#endif

COFUSION_VS_FN vec3 view_unpack_rgb(uint c) {
  return vec3(float(c & 0xFFu), float((c >> 8) & 0xFFu), float((c >> 16) & 0xFFu));
}

// Rounds half up (GLSL's round() may round halves either way), opaque alpha.
COFUSION_VS_FN uint view_pack_rgb(vec3 c) {
  vec3 q = clamp(floor(c + vec3(0.5f)), vec3(0.0f), vec3(255.0f));
  return uint(q.x) | (uint(q.y) << 8) | (uint(q.z) << 16) | (255u << 24);
}

// A jet-like colour map: 0 = dark blue, 0.5 = green, 1 = dark red; components in [0, 1].
COFUSION_VS_FN vec3 view_colour_map(float t) {
  float s = clamp(t, 0.0f, 1.0f);
  return clamp(vec3(1.5f) - abs(vec3(4.0f * s - 3.0f, 4.0f * s - 2.0f, 4.0f * s - 1.0f)), vec3(0.0f),
                           vec3(1.0f));
}

// Colour of a pixel won by a surfel with view-frame normal n_view at view-frame position p_view.
COFUSION_VS_FN vec3 view_shade(uint mode, uint surfel_rgba8, uint label_rgba8, vec3 n_view, vec3 p_view,
                               float confidence, float confidence_max, float ambient) {
  if (mode == VIEW_COLOUR_NORMAL) return (n_view * 0.5f + vec3(0.5f)) * 255.0f;
  vec3 base = view_unpack_rgb(surfel_rgba8);
  if (mode == VIEW_COLOUR_LABEL) base = view_unpack_rgb(label_rgba8);
  if (mode == VIEW_COLOUR_CONFIDENCE) base = view_colour_map(confidence / max(confidence_max, 1e-6f)) * 255.0f;
  float len = length(p_view);
  float cos_view = len > 0.0f ? abs(dot(n_view, p_view)) / len : 1.0f;
  return base * (ambient + (1.0f - ambient) * min(cos_view, 1.0f));
}

#ifdef __cplusplus
}  // namespace cofusion::view_shading
#endif
#undef COFUSION_VS_FN
#endif  // COFUSION_VIEW_SHADING_H
