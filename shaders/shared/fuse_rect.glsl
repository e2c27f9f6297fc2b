// fuse_count_new and fuse_update run one invocation per pixel of FuseParams' rectangle, in
// row-major order (blocks of COMPACTION_BLOCK pixels: new surfels get their slots in pixel order).
#ifndef COFUSION_FUSE_RECT_GLSL
#define COFUSION_FUSE_RECT_GLSL
#include "small_division.glsl"

// The rectangle's width and height within the image (0 when empty).
uvec2 fuse_rect_size(FuseParams p) {
  const uint x1 = min(p.rect_x1, p.width), y1 = min(p.rect_y1, p.height);
  return uvec2(x1 > p.rect_x0 ? x1 - p.rect_x0 : 0u, y1 > p.rect_y0 ? y1 - p.rect_y0 : 0u);
}

// The pixel of the rectangle's j-th (row-major) pixel, when j is inside it.
bool fuse_rect_pixel(FuseParams p, uint j, out uvec2 px) {
  const uvec2 size = fuse_rect_size(p);
  px = uvec2(0u);
  if (j >= size.x * size.y) return false;
  // The choice is the same for every invocation, so only one side runs (images up to about 1 MP
  // take the float quotient).
  const uint row = size.x * size.y < SMALL_QUOTIENT_LIMIT ? small_quotient(j, size.x) : j / size.x;
  px = uvec2(p.rect_x0 + j - row * size.x, p.rect_y0 + row);
  return true;
}

#endif
