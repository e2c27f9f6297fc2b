#version 460
// Middle pass of a stable stream compaction (host_device.h): turns each block's count of kept
// elements into the block's first destination, counter[counter_slot] + the counts of the blocks
// before it, and adds the total to counter[counter_slot]. One workgroup: each invocation sums a
// contiguous run of blocks, invocation 0 scans those sums, and each invocation writes its run's
// destinations (thousands of blocks for millions of elements: a few microseconds). With a
// count_slot, only the blocks that the GPU's count covers (CompactionScanParams).
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/small_division.glsl"
layout(local_size_x = COMPACTION_BLOCK) in;
layout(std430, binding = COMPACTION_SCAN_BINDING_BLOCKS) buffer Blocks { uint blocks[]; };
layout(std430, binding = COMPACTION_SCAN_BINDING_COUNTER) buffer Counter { uint counter[]; };
layout(push_constant) uniform Push { CompactionScanParams p; };
shared uint run_first[COMPACTION_BLOCK];
void main() {
  const uint t = gl_LocalInvocationIndex;
  uint block_count = p.block_count;
  if (p.count_slot != COMPACTION_FIXED_COUNT) {
    block_count = min(block_count, ceil_quotient(counter[p.count_slot], COMPACTION_BLOCK));
  }
  const uint per_run = (block_count + COMPACTION_BLOCK - 1u) / COMPACTION_BLOCK;
  const uint first = min(t * per_run, block_count), last = min(first + per_run, block_count);
  uint sum = 0u;
  for (uint b = first; b < last; ++b) sum += blocks[b];
  run_first[t] = sum;
  barrier();
  if (t == 0u) {
    uint next = counter[p.counter_slot];
    for (uint r = 0u; r < COMPACTION_BLOCK; ++r) {
      const uint n = run_first[r];
      run_first[r] = next;
      next += n;
    }
    counter[p.counter_slot] = next;
  }
  barrier();
  uint next = run_first[t];
  for (uint b = first; b < last; ++b) {
    const uint n = blocks[b];
    blocks[b] = next;
    next += n;
  }
}
