#pragma once
// Stable stream compaction (shaders/shared/host_device.h, "stable stream compaction"): the kernels
// that keep some of their elements count them per block of COMPACTION_BLOCK elements, this class
// records compaction_scan, which turns the counts into each block's first destination, and the
// same kernels then write their kept elements there, in source order. CPU reference in
// compaction_reference.h.
//
// Thread safety: each class holds only a pipeline; record() is const and may be called from
// several threads.
#include <cstddef>
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
  // With `count_slot` (not COMPACTION_FIXED_COUNT, not counter_slot), only the first
  // block_count(min(counter[count_slot], block_count * COMPACTION_BLOCK)) blocks are scanned: those
  // of a counting pass dispatched indirectly over that count (IndirectGroups).
  void record(gpu::CommandList& cmd, const gpu::BufferPtr& blocks, const gpu::BufferPtr& counter, uint32_t counter_slot,
              uint32_t block_count, uint32_t count_slot = COMPACTION_FIXED_COUNT) const;

 private:
  gpu::ComputePipeline scan_;
};

// Records indirect_groups: the workgroup counts of two indirect dispatches over
// n = min(counter[count_slot], bound) elements, written to `args` (IndirectGroups::kBytes; the
// first record at byte 0, the second at kSecondOffset), followed by the barrier that lets later
// dispatches read them. Kernels whose element count only the GPU knows (the model's count after
// fusion's new surfels) then skip the workgroups past it, where a direct dispatch over the host's
// bound runs them idle.
class IndirectGroups {
 public:
  explicit IndirectGroups(gpu::Context& ctx);
  static constexpr size_t kBytes = INDIRECT_GROUPS_WORDS * 4;
  static constexpr size_t kSecondOffset = INDIRECT_GROUPS_B_WORD * 4;
  void record(gpu::CommandList& cmd, const gpu::BufferPtr& counter, uint32_t count_slot, uint32_t bound,
              uint32_t group_size_a, uint32_t group_size_b, const gpu::BufferPtr& args) const;

 private:
  gpu::ComputePipeline groups_;
};

}  // namespace cofusion::kernels
