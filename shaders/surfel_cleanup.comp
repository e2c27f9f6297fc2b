#version 460
// Decides which surfels stay: unstable surfels (confidence below stable_confidence) not confirmed
// within the window go; surfels the live depth shows to be in free space (well in front of the
// observed surface) lose confidence and go once it reaches zero, so stale geometry of moved
// objects disappears. With p.merge, the merges surfel_merge_select/claim chose are applied first:
// the source is dropped, its target absorbs it (shared/surfel_merge.glsl). The counting pass of a
// stable compaction (host_device.h): each kept surfel, as it stays, goes to `decided` at its own
// index, and the block's kept count and keep mask to `blocks` and `keep_mask`; after
// compaction_scan, surfel_compact copies the kept ones into place without deciding again.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/rigid.glsl"
#include "shared/texel_access.glsl"
#include "shared/surfel_merge.glsl"
#include "shared/compaction.glsl"
layout(local_size_x = COMPACTION_BLOCK) in;
layout(binding = CLEANUP_BINDING_SRC) uniform usamplerBuffer src;  // texel view
// Surfels as three uvec4s each (surfel_texel), so that a surfel is three whole-vector stores.
layout(std430, binding = CLEANUP_BINDING_DECIDED) writeonly buffer Decided { uvec4 decided[]; };
layout(binding = CLEANUP_BINDING_DEPTH) uniform usamplerBuffer depth_m;  // texel view of float metres
layout(std430, binding = CLEANUP_BINDING_COUNTER) readonly buffer Counter { uint counter[]; };
layout(binding = CLEANUP_BINDING_MERGE_TARGET) uniform usamplerBuffer merge_target;  // texel view of uint
layout(binding = CLEANUP_BINDING_MERGE_CLAIM) uniform usamplerBuffer merge_claim;    // texel view of uint
layout(std430, binding = CLEANUP_BINDING_BLOCKS) writeonly buffer Blocks { uint blocks[]; };
layout(std430, binding = CLEANUP_BINDING_KEEP_MASK) writeonly buffer KeepMask { uint keep_mask[]; };
layout(push_constant) uniform Push { CleanupParams p; };

// Whether surfel i stays; `s` gets it as it stays (merged, free-space penalty applied).
bool kept(uint i, out Surfel s) {
  s = surfel_at(src, i);
  if (p.merge != 0u) {
    const uint t = texel_uint(merge_target, i);
    if (t != MERGE_NONE && texel_uint(merge_target, t) == MERGE_NONE && texel_uint(merge_claim, t) == i) return false;
    const uint c = texel_uint(merge_claim, i);
    if (c != MERGE_NONE) s = merge_surfels(s, surfel_at(src, c));
  }
  if (s.confidence < p.stable_confidence && p.frame - s.created_frame > p.unstable_window_frames) return false;
  vec3 pc = rigid_apply(p.T_camera_model, vec3(s.px, s.py, s.pz));
  if (pc.z > 1e-3) {
    int x = int(round(p.fx * pc.x / pc.z + p.cx)), y = int(round(p.fy * pc.y / pc.z + p.cy));
    if (x >= 0 && y >= 0 && x < int(p.width) && y < int(p.height)) {
      float d = texel_float(depth_m, uint(y) * p.width + uint(x));
      if (d > 0.0 && pc.z < d - p.free_space_margin_rel * d) {
        s.confidence -= p.free_space_penalty;
        if (s.confidence <= 0.0) return false;
      }
    }
  }
  return true;
}

void main() {
  // The count after fusion's new surfels lives on the GPU (counter[0]); surfel_count bounds the
  // dispatch from the host side.
  const uint i = gl_GlobalInvocationID.x;
  Surfel s;
  const bool keep = i < min(p.surfel_count, counter[0]) && kept(i, s);
  if (keep)
    for (uint k = 0u; k < 3u; ++k) decided[3u * i + k] = surfel_texel(s, k);
  uint block_total;
  compaction_rank(keep, block_total);
  const uint local = gl_LocalInvocationIndex;
  if (local == 0u) blocks[gl_WorkGroupID.x] = block_total;
  if (local < COMPACTION_MASK_WORDS) keep_mask[gl_WorkGroupID.x * COMPACTION_MASK_WORDS + local] = compaction_bits[local];
}
