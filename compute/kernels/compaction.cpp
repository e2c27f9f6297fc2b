#include "kernels/compaction.h"

#include "embedded_shaders.h"

namespace cofusion::kernels {

CompactionScan::CompactionScan(gpu::Context& ctx)
    : scan_(ctx, "compaction_scan", shaders::compaction_scan_comp(), 2, sizeof(gpu_layout::CompactionScanParams)) {}

void CompactionScan::record(gpu::CommandList& cmd, const gpu::BufferPtr& blocks, const gpu::BufferPtr& counter,
                            uint32_t counter_slot, uint32_t block_count) const {
  if (block_count == 0) return;  // nothing counted: the counter stays
  const gpu_layout::CompactionScanParams p{block_count, counter_slot};
  cmd.dispatch(scan_, {blocks, counter}, p, 1);
}

}  // namespace cofusion::kernels
