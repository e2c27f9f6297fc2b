#pragma once
// Stable stream compaction (shaders/shared/host_device.h, "stable stream compaction"): the kernels
// that keep some of their elements count them per block of COMPACTION_BLOCK elements, this class
// records compaction_scan, which turns the counts into each block's first destination, and the
// same kernels then write their kept elements there, in source order. CPU reference in
// compaction_reference.h.
//
// Thread safety: holds only a pipeline; record() is const and may be called from several threads.
#include <cstdint>

#include "gpu/stream.h"
#include "shared/host_device.h"

namespace cofusion::kernels {

class CompactionScan {
 public:
  explicit CompactionScan(gpu::Context& ctx);

  // Blocks (workgroups) covering `elements`.
  static uint32_t block_count(uint32_t elements) { return gpu::group_count(elements, COMPACTION_BLOCK); }
  // Bytes of a blocks buffer for `elements` (at least one uint, so that it can be bound).
  static size_t blocks_bytes(uint32_t elements) { return size_t(block_count(elements) > 0 ? block_count(elements) : 1) * 4; }
  // Bytes of a keep mask for `elements` (COMPACTION_MASK_WORDS uints per block, at least one block):
  // the counting pass's decisions, for a writing pass that only copies.
  static size_t keep_mask_bytes(uint32_t elements) { return blocks_bytes(elements) * COMPACTION_MASK_WORDS; }

  // `blocks` (uint per block, the counting pass's counts) becomes each block's first destination,
  // counter[counter_slot] plus the counts of the blocks before it; counter[counter_slot] grows by
  // the total. The caller places barriers before (the counts) and after (the destinations).
  void record(gpu::CommandList& cmd, const gpu::BufferPtr& blocks, const gpu::BufferPtr& counter, uint32_t counter_slot,
              uint32_t block_count) const;

 private:
  gpu::ComputePipeline scan_;
};

}  // namespace cofusion::kernels
