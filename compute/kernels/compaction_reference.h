#pragma once
// CPU reference of the stable stream compaction (kernels/compaction.h): the counting pass, the
// scan of the blocks (compaction_scan) and the destinations the writing pass gives.
#include <cstdint>
#include <vector>

namespace cofusion::kernels::reference {

// Per block of COMPACTION_BLOCK elements, the number of kept ones (keep[i] != 0).
std::vector<uint32_t> compaction_block_counts(const std::vector<uint32_t>& keep);
// compaction_scan: each block's count becomes its first destination, `first` plus the counts
// before it. Returns the destination after the last kept element (the new counter value).
uint32_t compaction_scan(std::vector<uint32_t>& blocks, uint32_t first);
// The indices of the kept elements, in order (what a stable compaction writes).
std::vector<uint32_t> compacted_indices(const std::vector<uint32_t>& keep);

}  // namespace cofusion::kernels::reference
