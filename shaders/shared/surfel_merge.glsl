// Merging two surfels of one surface (GLSL only; surfel_reference.cpp mirrors it).
#ifndef COFUSION_SURFEL_MERGE_GLSL
#define COFUSION_SURFEL_MERGE_GLSL
#include "rigid.glsl"
// `kept` absorbs `merged`: position, normal, colour and radius are averaged weighted by
// confidence; the confidence is the larger of the two, not their sum: two unconfirmed neighbours
// must not make a stable surfel that enters the prediction (summed, TUM fr1/rpy's ATE went from
// 2.3 to 2.7 cm). The surfel is as old as the older one and was last seen when the later one was.
Surfel merge_surfels(Surfel kept, Surfel merged) {
  float ca = kept.confidence, cb = merged.confidence;
  float w = 1.0 / max(ca + cb, 1e-20);
  vec3 pos = (ca * vec3(kept.px, kept.py, kept.pz) + cb * vec3(merged.px, merged.py, merged.pz)) * w;
  vec3 nrm = normalize(ca * vec3(kept.nx, kept.ny, kept.nz) + cb * vec3(merged.nx, merged.ny, merged.nz));
  vec3 col = (ca * unpack_rgb(kept.colour_rgba8) + cb * unpack_rgb(merged.colour_rgba8)) * w;
  Surfel s = kept;
  s.px = pos.x; s.py = pos.y; s.pz = pos.z;
  s.nx = nrm.x; s.ny = nrm.y; s.nz = nrm.z;
  s.colour_rgba8 = pack_rgb(col);
  s.radius_m = (ca * kept.radius_m + cb * merged.radius_m) * w;
  s.confidence = max(ca, cb);
  s.created_frame = min(kept.created_frame, merged.created_frame);
  s.last_seen_frame = max(kept.last_seen_frame, merged.last_seen_frame);
  return s;
}
#endif
