#version 460
// Compaction test kernel (shared/compaction.glsl): the indices of the nonzero flags, in order.
// COMPACTION_PASS_COUNT writes each block's count; COMPACTION_PASS_WRITE (after compaction_scan)
// writes out[k] = index of the k-th nonzero flag.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/compaction.glsl"
layout(local_size_x = COMPACTION_BLOCK) in;
layout(std430, binding = TEST_COMPACTION_BINDING_FLAGS) readonly buffer Flags { uint flags[]; };
layout(std430, binding = TEST_COMPACTION_BINDING_BLOCKS) buffer Blocks { uint blocks[]; };
layout(std430, binding = TEST_COMPACTION_BINDING_OUT) writeonly buffer Out { uint kept[]; };
layout(push_constant) uniform Push { TestCompactionParams p; };
void main() {
  const uint i = gl_GlobalInvocationID.x;
  const bool keep = i < p.count && flags[i] != 0u;
  uint block_total;
  const uint rank = compaction_rank(keep, block_total);
  if (p.pass == COMPACTION_PASS_COUNT) {
    if (gl_LocalInvocationIndex == 0u) blocks[gl_WorkGroupID.x] = block_total;
  } else if (keep) {
    kept[blocks[gl_WorkGroupID.x] + rank] = i;
  }
}
