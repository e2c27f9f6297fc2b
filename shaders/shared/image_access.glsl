// Helpers for images stored row-major in storage buffers (GLSL only).
#ifndef COFUSION_IMAGE_ACCESS_GLSL
#define COFUSION_IMAGE_ACCESS_GLSL

uint pixel_index(uvec2 p, uint width) { return p.y * width + p.x; }
ivec2 clamp_pixel(ivec2 p, uint width, uint height) {
  return clamp(p, ivec2(0), ivec2(int(width) - 1, int(height) - 1));
}

#endif
