#include "kernels/compaction_reference.h"

#include <algorithm>
#include <cstddef>

#include "shared/host_device.h"

namespace cofusion::kernels::reference {

std::vector<uint32_t> compaction_block_counts(const std::vector<uint32_t>& keep) {
  std::vector<uint32_t> counts((keep.size() + COMPACTION_BLOCK - 1) / COMPACTION_BLOCK, 0u);
  for (std::size_t i = 0; i < keep.size(); ++i) counts[i / COMPACTION_BLOCK] += keep[i] != 0;
  return counts;
}

uint32_t compaction_scan(std::vector<uint32_t>& blocks, uint32_t first) {
  uint32_t next = first;
  for (uint32_t& b : blocks) {
    const uint32_t count = b;
    b = next;
    next += count;
  }
  return next;
}

uint32_t counted_block_count(uint32_t count, uint32_t block_count) {
  const uint64_t covering = (uint64_t(count) + COMPACTION_BLOCK - 1) / COMPACTION_BLOCK;
  return uint32_t(std::min<uint64_t>(covering, block_count));
}

static_assert(INDIRECT_GROUPS_B_WORD == 3 && INDIRECT_GROUPS_WORDS == 6, "the records as indirect_groups() returns them");

std::array<uint32_t, 6> indirect_groups(uint32_t count, uint32_t bound, uint32_t group_size_a, uint32_t group_size_b) {
  const uint64_t n = std::min(count, bound);
  return {uint32_t((n + group_size_a - 1) / group_size_a), 1u, 1u, uint32_t((n + group_size_b - 1) / group_size_b), 1u, 1u};
}

std::vector<uint32_t> compacted_indices(const std::vector<uint32_t>& keep) {
  std::vector<uint32_t> out;
  for (std::size_t i = 0; i < keep.size(); ++i)
    if (keep[i] != 0) out.push_back(uint32_t(i));
  return out;
}

}  // namespace cofusion::kernels::reference
