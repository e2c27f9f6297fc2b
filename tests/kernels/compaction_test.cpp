// The stable stream compaction (compute/kernels/compaction.h: the counting and writing passes of
// shared/compaction.glsl through test_compaction.comp, and compaction_scan) against its CPU
// reference, bit-exact (integer work), over edge sizes: nothing, one element, a block less one,
// one block, a block and one, several thousand blocks (more blocks than the scan's invocations),
// with every element kept, none, and random ones.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "embedded_shaders.h"
#include "kernels/compaction.h"
#include "kernels/compaction_reference.h"
#include "support/gpu_fixture.h"

namespace cofusion::test {
namespace {
namespace ref = kernels::reference;
namespace L = gpu_layout;

enum class Keep { kAll, kNone, kRandom, kSparse };

std::vector<uint32_t> make_flags(uint32_t n, Keep keep, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<uint32_t> flags(n);
  for (auto& f : flags) {
    const uint32_t r = rng();
    f = keep == Keep::kAll ? 1u + r % 7 : keep == Keep::kNone ? 0u : keep == Keep::kRandom ? r % 2 : (r % 97 == 0 ? r : 0u);
  }
  return flags;
}

std::string describe(uint32_t n, Keep keep) {
  const char* names[] = {"all kept", "none kept", "half kept", "1% kept"};
  return std::to_string(n) + " elements, " + names[int(keep)];
}

class Compaction : public GpuTest {
 protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (!scan_) {
      scan_ = std::make_unique<kernels::CompactionScan>(ctx());
      compact_ = std::make_unique<gpu::ComputePipeline>(ctx(), "test_compaction", shaders::test_compaction_comp(), 3,
                                                        uint32_t(sizeof(L::TestCompactionParams)));
    }
  }
  static void TearDownTestSuite() {
    compact_.reset();
    scan_.reset();
    GpuTest::TearDownTestSuite();
  }
  static std::unique_ptr<kernels::CompactionScan> scan_;
  static std::unique_ptr<gpu::ComputePipeline> compact_;
};
std::unique_ptr<kernels::CompactionScan> Compaction::scan_;
std::unique_ptr<gpu::ComputePipeline> Compaction::compact_;

TEST_F(Compaction, CountScanAndWriteMatchReference) {
  const uint32_t sizes[] = {0, 1, COMPACTION_BLOCK - 1, COMPACTION_BLOCK, COMPACTION_BLOCK + 1, 100003, 2'000'001};
  for (uint32_t n : sizes)
    for (Keep keep : {Keep::kAll, Keep::kNone, Keep::kRandom, Keep::kSparse}) {
      const std::string what = describe(n, keep);
      const auto flags = make_flags(n, keep, n + unsigned(keep));
      const uint32_t blocks = kernels::CompactionScan::block_count(n);
      const uint32_t first = 17;  // as fusion's new surfels start at the model's count
      auto flag_buffer = upload(flags, "flags");
      auto block_buffer = gpu::Buffer::create(ctx(), kernels::CompactionScan::blocks_bytes(n), "blocks");
      auto out = gpu::Buffer::create(ctx(), (size_t(n) + first + 1) * 4, "out");
      auto counter = upload(std::vector<uint32_t>{5, first, 0, 0}, "counter");
      L::TestCompactionParams p{n, COMPACTION_PASS_COUNT};
      stream().run([&](gpu::CommandList& c) { c.dispatch(*compact_, {flag_buffer, block_buffer, out}, p, blocks); });

      auto cpu_blocks = ref::compaction_block_counts(flags);
      EXPECT_EQ(stream().download<uint32_t>(block_buffer, blocks), cpu_blocks) << "counts, " << what;

      stream().run([&](gpu::CommandList& c) { scan_->record(c, block_buffer, counter, 1, blocks); });
      const uint32_t cpu_end = ref::compaction_scan(cpu_blocks, first);
      EXPECT_EQ(stream().download<uint32_t>(block_buffer, blocks), cpu_blocks) << "first destinations, " << what;
      const auto gpu_counter = stream().download<uint32_t>(counter, 2);
      EXPECT_EQ(gpu_counter[1], cpu_end) << what;
      EXPECT_EQ(gpu_counter[0], 5u) << "other counter slots stay, " << what;

      p.pass = COMPACTION_PASS_WRITE;
      stream().run([&](gpu::CommandList& c) { c.dispatch(*compact_, {flag_buffer, block_buffer, out}, p, blocks); });
      const auto cpu_kept = ref::compacted_indices(flags);
      ASSERT_EQ(cpu_end - first, cpu_kept.size()) << what;
      const auto gpu_out = stream().download<uint32_t>(out, first + cpu_kept.size());
      EXPECT_TRUE(std::equal(cpu_kept.begin(), cpu_kept.end(), gpu_out.begin() + first)) << "kept indices, " << what;
    }
}

// The scan alone over many blocks with large counts (more blocks than its 256 invocations, a
// count that is not a multiple of them, counts up to a whole block).
TEST_F(Compaction, ScanOfManyBlocksMatchesReference) {
  for (uint32_t blocks : {1u, 255u, 256u, 257u, 70001u}) {
    std::mt19937 rng(blocks);
    std::vector<uint32_t> counts(blocks);
    for (auto& c : counts) c = rng() % (COMPACTION_BLOCK + 1);
    auto block_buffer = upload(counts, "blocks");
    auto counter = upload(std::vector<uint32_t>{1000, 0, 0, 0}, "counter");
    stream().run([&](gpu::CommandList& c) { scan_->record(c, block_buffer, counter, 0, blocks); });
    auto expected = counts;
    const uint32_t end = ref::compaction_scan(expected, 1000);
    EXPECT_EQ(stream().download<uint32_t>(block_buffer, blocks), expected) << blocks << " blocks";
    EXPECT_EQ(stream().download<uint32_t>(counter, 1)[0], end) << blocks << " blocks";
  }
}

}  // namespace
}  // namespace cofusion::test
