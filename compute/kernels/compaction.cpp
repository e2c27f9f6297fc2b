#include "kernels/compaction.h"

#include <string>

#include "common/error.h"
#include "embedded_shaders.h"

namespace cofusion::kernels {

CompactionScan::CompactionScan(gpu::Context& ctx)
    : scan_(ctx, "compaction_scan", shaders::compaction_scan_comp(), 2, sizeof(gpu_layout::CompactionScanParams)) {}

void CompactionScan::record(gpu::CommandList& cmd, const gpu::BufferPtr& blocks, const gpu::BufferPtr& counter,
                            uint32_t counter_slot, uint32_t block_count, uint32_t count_slot) const {
  if (block_count == 0) return;  // nothing counted: the counter stays
  if (count_slot == counter_slot) throw Error("compaction_scan: its count and its destination share counter slot " +
                                              std::to_string(counter_slot));
  const gpu_layout::CompactionScanParams p{block_count, counter_slot, count_slot, 0};
  cmd.dispatch(scan_, {blocks, counter}, p, 1);
}

IndirectGroups::IndirectGroups(gpu::Context& ctx)
    : groups_(ctx, "indirect_groups", shaders::indirect_groups_comp(), 2, sizeof(gpu_layout::IndirectGroupsParams)) {}

void IndirectGroups::record(gpu::CommandList& cmd, const gpu::BufferPtr& counter, uint32_t count_slot, uint32_t bound,
                            uint32_t group_size_a, uint32_t group_size_b, const gpu::BufferPtr& args) const {
  if (group_size_a == 0 || group_size_b == 0) throw Error("indirect_groups: a group size of 0");
  if (!args || args->size() < kBytes)
    throw Error("indirect_groups: the arguments buffer needs " + std::to_string(kBytes) + " bytes");
  if (args->usage() != gpu::BufferUsage::Indirect)
    throw Error("indirect_groups: the arguments buffer '" + args->name() + "' was not created with BufferUsage::Indirect");
  const gpu_layout::IndirectGroupsParams p{count_slot, bound, group_size_a, group_size_b};
  cmd.dispatch(groups_, {counter, args}, p, 1);
  cmd.indirect_barrier();
}

}  // namespace cofusion::kernels
