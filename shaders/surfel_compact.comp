#version 460
// The writing pass of cleanup's and remove_region's stable compaction (host_device.h): copies
// each surfel the counting pass kept (its bit in the block's keep mask) to its block's first
// destination plus the number of kept surfels before it in the block. It decides nothing, so
// surfel_cleanup's merge and free-space tests run once per surfel.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/compaction.glsl"
layout(local_size_x = COMPACTION_BLOCK) in;
layout(binding = SURFEL_COMPACT_BINDING_SRC) uniform usamplerBuffer src;  // texel view
layout(std430, binding = SURFEL_COMPACT_BINDING_DST) writeonly buffer Dst { Surfel dst[]; };
layout(std430, binding = SURFEL_COMPACT_BINDING_BLOCKS) readonly buffer Blocks { uint blocks[]; };
layout(std430, binding = SURFEL_COMPACT_BINDING_KEEP_MASK) readonly buffer KeepMask { uint keep_mask[]; };

void main() {
  const uint local = gl_LocalInvocationIndex;
  const uint word = keep_mask[gl_WorkGroupID.x * COMPACTION_MASK_WORDS + (local >> 5u)];
  const bool keep = ((word >> (local & 31u)) & 1u) != 0u;
  uint block_total;
  const uint rank = compaction_rank(keep, block_total);
  if (keep) dst[blocks[gl_WorkGroupID.x] + rank] = surfel_at(src, gl_GlobalInvocationID.x);
}
