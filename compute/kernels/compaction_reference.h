#pragma once
// CPU reference of the stable stream compaction (kernels/compaction.h): the counting pass, the
// scan of the blocks (compaction_scan) and the destinations the writing pass gives.
#include <array>
#include <cstdint>
#include <vector>

namespace cofusion::kernels::reference {

// Per block of COMPACTION_BLOCK elements, the number of kept ones (keep[i] != 0).
std::vector<uint32_t> compaction_block_counts(const std::vector<uint32_t>& keep);
// compaction_scan: each block's count becomes its first destination, `first` plus the counts
// before it. Returns the destination after the last kept element (the new counter value).
uint32_t compaction_scan(std::vector<uint32_t>& blocks, uint32_t first);
// compaction_scan with a count_slot (CompactionScan::record): the blocks it scans for a count of
// `count` elements and at most `block_count` blocks.
uint32_t counted_block_count(uint32_t count, uint32_t block_count);
// indirect_groups: the six words of its two VkDispatchIndirectCommand records for a counter value
// of `count` (IndirectGroupsParams).
std::array<uint32_t, 6> indirect_groups(uint32_t count, uint32_t bound, uint32_t group_size_a, uint32_t group_size_b);
// The indices of the kept elements, in order (what a stable compaction writes).
std::vector<uint32_t> compacted_indices(const std::vector<uint32_t>& keep);

}  // namespace cofusion::kernels::reference
