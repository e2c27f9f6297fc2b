// Stable stream compaction inside one workgroup of COMPACTION_BLOCK invocations (one element each,
// element = workgroup's first + gl_LocalInvocationIndex); see host_device.h. A bit per invocation
// in shared memory and popcounts: two barriers, no subgroup operations (their mapping onto
// local invocation indices is not fixed by Vulkan, and the rank must follow the index).
#ifndef COFUSION_COMPACTION_GLSL
#define COFUSION_COMPACTION_GLSL

shared uint compaction_bits[COMPACTION_BLOCK / 32];

// The number of kept elements before this invocation's in its block; `block_total` gets the
// block's number of kept elements. Every invocation of the workgroup must call it, in uniform
// control flow (it has barriers). Afterwards compaction_bits holds the block's keep mask
// (COMPACTION_MASK_WORDS words, host_device.h's layout) until the next call.
uint compaction_rank(bool keep, out uint block_total) {
  const uint i = gl_LocalInvocationIndex, word = i >> 5u, bit = i & 31u;
  if (i < COMPACTION_BLOCK / 32) compaction_bits[i] = 0u;
  barrier();
  if (keep) atomicOr(compaction_bits[word], 1u << bit);
  barrier();
  uint rank = uint(bitCount(compaction_bits[word] & ((1u << bit) - 1u))), total = 0u;
  for (uint w = 0u; w < COMPACTION_BLOCK / 32; ++w) {
    const uint n = uint(bitCount(compaction_bits[w]));
    if (w < word) rank += n;
    total += n;
  }
  block_total = total;
  return rank;
}

#endif
