#include "kernels/compaction_reference.h"

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

std::vector<uint32_t> compacted_indices(const std::vector<uint32_t>& keep) {
  std::vector<uint32_t> out;
  for (std::size_t i = 0; i < keep.size(); ++i)
    if (keep[i] != 0) out.push_back(uint32_t(i));
  return out;
}

}  // namespace cofusion::kernels::reference
