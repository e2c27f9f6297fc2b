#version 460
// The writing pass of cleanup's and remove_region's stable compaction (host_device.h): copies
// each surfel the counting pass kept (its bit in the block's keep mask) to its block's first
// destination plus the number of kept surfels before it in the block. It decides nothing, so
// surfel_cleanup's merge and free-space tests run once per surfel.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
layout(local_size_x = COMPACTION_BLOCK) in;
layout(binding = SURFEL_COMPACT_BINDING_SRC) uniform usamplerBuffer src;  // texel view
// Surfels as three uvec4s each (texel_access.glsl's layout): whole-vector stores, bits unchanged.
layout(std430, binding = SURFEL_COMPACT_BINDING_DST) writeonly buffer Dst { uvec4 dst[]; };
layout(std430, binding = SURFEL_COMPACT_BINDING_BLOCKS) readonly buffer Blocks { uint blocks[]; };
layout(std430, binding = SURFEL_COMPACT_BINDING_KEEP_MASK) readonly buffer KeepMask { uint keep_mask[]; };

void main() {
  const uint local = gl_LocalInvocationIndex, first_word = gl_WorkGroupID.x * COMPACTION_MASK_WORDS;
  const uint word = keep_mask[first_word + (local >> 5u)], bit = local & 31u;
  if (((word >> bit) & 1u) == 0u) return;
  // Rank from the mask itself (the bits below this one, then the block's earlier words): no
  // shared memory and no barriers, which cost more than the copy on lavapipe.
  uint rank = uint(bitCount(word & ((1u << bit) - 1u)));
  for (uint w = 0u; w < (local >> 5u); ++w) rank += uint(bitCount(keep_mask[first_word + w]));
  const uint from = 3u * gl_GlobalInvocationID.x, to = 3u * (blocks[gl_WorkGroupID.x] + rank);
  for (uint k = 0u; k < 3u; ++k) dst[to + k] = texelFetch(src, int(from + k));
}
