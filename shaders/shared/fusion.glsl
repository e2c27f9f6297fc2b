// Per-pixel quantities of surfel fusion (GLSL only; fusion_reference.cpp mirrors them).
#ifndef COFUSION_FUSION_GLSL
#define COFUSION_FUSION_GLSL
// Confidence weight of a live measurement: measurements near the image centre are trusted more
// (ElasticFusion: exp(-gamma^2 / (2 * 0.6^2)), gamma = normalised radial distance).
float measurement_weight(uvec2 px, float cx, float cy) {
  float gamma = length(vec2(float(px.x) - cx, float(px.y) - cy)) / length(vec2(cx, cy));
  return exp(-gamma * gamma / (2.0 * 0.36));
}
// Disc radius that covers the pixel footprint at depth z, stretched by the viewing angle
// (capped at grazing angles): sqrt(2) * z / f / |cos(angle)|, as ElasticFusion.
float surfel_radius(vec3 v, vec3 n, float f) {
  float cos_angle = abs(dot(n, normalize(v)));
  return 1.41421356 * v.z / f / max(cos_angle, 0.3);
}
#endif
