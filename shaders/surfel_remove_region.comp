#version 460
// Decides which surfels of a model stay when a labelled live region covers part of it: those
// lying in front of (or at) a live pixel of the region go. Co-Fusion: an object that was
// background and now moves on its own becomes a new model, and the background's copy of it must
// go; surfels behind the live surface (background the object occluded) stay. Layout and rule in
// shared/host_device.h. The counting pass of a stable compaction: the block's kept count and keep
// mask go to `blocks` and `keep_mask`; after compaction_scan, surfel_compact copies the kept
// surfels in their order.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/rigid.glsl"
#include "shared/compaction.glsl"
layout(local_size_x = COMPACTION_BLOCK) in;
layout(binding = REMOVE_REGION_BINDING_SRC) uniform usamplerBuffer src;  // texel view
layout(std430, binding = REMOVE_REGION_BINDING_KEEP_MASK) writeonly buffer KeepMask { uint keep_mask[]; };
layout(binding = REMOVE_REGION_BINDING_DEPTH) uniform usamplerBuffer depth_m;  // texel view of float
layout(binding = REMOVE_REGION_BINDING_LABELS) uniform usamplerBuffer labels;  // texel view of uint
layout(std430, binding = REMOVE_REGION_BINDING_COUNTER) readonly buffer Counter { uint counter[]; };
layout(std430, binding = REMOVE_REGION_BINDING_BLOCKS) writeonly buffer Blocks { uint blocks[]; };
layout(push_constant) uniform Push { RemoveRegionParams p; };

// Whether the surfel at model-frame position `position` stays: it does not lie in front of (or at)
// a live pixel of the region.
bool kept(vec3 position) {
  vec3 pc = rigid_apply(p.T_camera_model, position);
  if (pc.z > 1e-3) {
    float x = p.fx * pc.x / pc.z + p.cx, y = p.fy * pc.y / pc.z + p.cy;
    // Nearest pixel, rounding halves up (GLSL round() leaves the direction to the driver).
    if (x >= -0.5 && y >= -0.5 && x < float(p.width) - 0.5 && y < float(p.height) - 0.5) {
      uint k = uint(floor(y + 0.5)) * p.width + uint(floor(x + 0.5));
      float d = texel_float(depth_m, k);
      if (texel_uint(labels, k) == p.label && d > 0.0 && pc.z < d * (1.0 + p.margin_rel)) return false;
    }
  }
  return true;
}

void main() {
  const uint i = gl_GlobalInvocationID.x;
  const bool keep = i < min(p.surfel_count, counter[0]) && kept(surfel_position_confidence(src, i).xyz);
  uint block_total;
  compaction_rank(keep, block_total);
  const uint local = gl_LocalInvocationIndex;
  if (local == 0u) blocks[gl_WorkGroupID.x] = block_total;
  if (local < COMPACTION_MASK_WORDS) keep_mask[gl_WorkGroupID.x * COMPACTION_MASK_WORDS + local] = compaction_bits[local];
}
