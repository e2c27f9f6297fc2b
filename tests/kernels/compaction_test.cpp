// The stable stream compaction (compute/kernels/compaction.h: the counting and writing passes of
// shared/compaction.glsl through test_compaction.comp, and compaction_scan) against its CPU
// reference, bit-exact (integer work), over edge sizes: nothing, one element, a block less one,
// one block, a block and one, several thousand blocks (more blocks than the scan's invocations),
// with every element kept, none, and random ones; the scan of a count only the GPU knows and the
// workgroup counts of indirect dispatches over it (indirect_groups).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "common/error.h"
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

// The scan with a count only the GPU knows (count_slot): it scans the blocks that cover that
// count, never more than block_count, and leaves the blocks past them (garbage here) as they are.
TEST_F(Compaction, ScanOfTheGpusCountMatchesReference) {
  const uint32_t most_blocks = 300;  // more than the scan's invocations
  const uint32_t counts[] = {0, 1, COMPACTION_BLOCK - 1, COMPACTION_BLOCK, COMPACTION_BLOCK + 1,
                             77 * COMPACTION_BLOCK + 3, most_blocks * COMPACTION_BLOCK - 1, most_blocks * COMPACTION_BLOCK,
                             most_blocks * COMPACTION_BLOCK + 1, 0xFFFFFFFFu};
  for (uint32_t count : counts) {
    std::mt19937 rng(count);
    std::vector<uint32_t> blocks(most_blocks);
    const uint32_t scanned = ref::counted_block_count(count, most_blocks);
    for (uint32_t b = 0; b < most_blocks; ++b) blocks[b] = b < scanned ? rng() % (COMPACTION_BLOCK + 1) : 0x7777u;
    auto block_buffer = upload(blocks, "blocks");
    auto counter = upload(std::vector<uint32_t>{count, 40, 0, 0}, "counter");
    stream().run([&](gpu::CommandList& c) { scan_->record(c, block_buffer, counter, 1, most_blocks, 0); });
    std::vector<uint32_t> expected(blocks.begin(), blocks.begin() + scanned);
    const uint32_t end = ref::compaction_scan(expected, 40);
    expected.insert(expected.end(), blocks.begin() + scanned, blocks.end());
    EXPECT_EQ(stream().download<uint32_t>(block_buffer, most_blocks), expected) << "count " << count;
    EXPECT_EQ(stream().download<uint32_t>(counter, 2), (std::vector<uint32_t>{count, end})) << "count " << count;
  }
  auto counter = upload(std::vector<uint32_t>{1, 0, 0, 0}, "counter");
  auto block_buffer = upload(std::vector<uint32_t>{1}, "blocks");
  EXPECT_THROW(stream().run([&](gpu::CommandList& c) { scan_->record(c, block_buffer, counter, 0, 1, 0); }), Error)
      << "a count slot that is also the destination";
}

// indirect_groups against its reference, over counts at the edges of both group sizes, the
// bound and 2^32, and the indirect dispatches it feeds: test_compaction's counting pass over the
// GPU's count writes exactly the blocks that cover it.
TEST_F(Compaction, IndirectGroupsMatchReferenceAndDispatch) {
  const kernels::IndirectGroups groups(ctx());
  const uint32_t bound = 5000;
  const uint32_t counts[] = {0, 1, 127, 128, 129, COMPACTION_BLOCK, COMPACTION_BLOCK + 1, bound - 1, bound, bound + 1,
                             0xFFFFFFFEu, 0xFFFFFFFFu};
  for (uint32_t group_b : {uint32_t(COMPACTION_BLOCK), 1u, 7u})
    for (uint32_t count : counts) {
      const std::string what = "count " + std::to_string(count) + ", groups of 128 and " + std::to_string(group_b);
      auto counter = upload(std::vector<uint32_t>{9, count, 0, 0}, "counter");
      auto args = gpu::Buffer::create(ctx(), kernels::IndirectGroups::kBytes, "args", gpu::BufferUsage::Indirect);
      stream().run([&](gpu::CommandList& c) { groups.record(c, counter, 1, bound, 128, group_b, args); });
      const auto expected = ref::indirect_groups(count, bound, 128, group_b);
      EXPECT_EQ(stream().download<uint32_t>(args, 6), std::vector<uint32_t>(expected.begin(), expected.end())) << what;
      if (group_b != COMPACTION_BLOCK) continue;

      // The counting pass dispatched from the second record over a flag buffer of `bound` elements.
      const auto flags = make_flags(bound, Keep::kAll, count);
      auto flag_buffer = upload(flags, "flags");
      const uint32_t most_blocks = kernels::CompactionScan::block_count(bound);
      auto block_buffer = upload(std::vector<uint32_t>(most_blocks, 0x7777u), "blocks");
      auto out = gpu::Buffer::create(ctx(), 4, "out");
      const L::TestCompactionParams p{bound, COMPACTION_PASS_COUNT};
      stream().run([&](gpu::CommandList& c) {
        c.dispatch_indirect(*compact_, {flag_buffer, block_buffer, out}, p, args, kernels::IndirectGroups::kSecondOffset);
      });
      const auto gpu_blocks = stream().download<uint32_t>(block_buffer, most_blocks);
      const auto all_counts = ref::compaction_block_counts(flags);
      for (uint32_t b = 0; b < most_blocks; ++b)
        EXPECT_EQ(gpu_blocks[b], b < expected[3] ? all_counts[b] : 0x7777u) << "block " << b << ", " << what;
    }
  EXPECT_EQ(ref::indirect_groups(0xFFFFFFFFu, 0xFFFFFFFFu, 1, 128)[3], 0x2000000u) << "the reference near 2^32";
  auto args = gpu::Buffer::create(ctx(), kernels::IndirectGroups::kBytes - 4, "short args", gpu::BufferUsage::Indirect);
  auto counter = upload(std::vector<uint32_t>{1, 0, 0, 0}, "counter");
  EXPECT_THROW(stream().run([&](gpu::CommandList& c) { groups.record(c, counter, 0, 1, 128, 256, args); }), Error);
  auto plain_args = gpu::Buffer::create(ctx(), kernels::IndirectGroups::kBytes, "plain args");
  EXPECT_THROW(stream().run([&](gpu::CommandList& c) { groups.record(c, counter, 0, 1, 128, 256, plain_args); }), Error)
      << "arguments in a buffer without the indirect usage";
  auto indirect = gpu::Buffer::create(ctx(), 16, "indirect counter", gpu::BufferUsage::Indirect);
  EXPECT_THROW(stream().run([&](gpu::CommandList& c) {
                 const L::TestCompactionParams p{1, COMPACTION_PASS_COUNT};
                 c.dispatch_indirect(*compact_, {counter, counter, counter}, p, indirect, 8);
               }),
               Error)
      << "arguments past the buffer's end";
  try {
    stream().run([&](gpu::CommandList& c) {
      const L::TestCompactionParams p{1, COMPACTION_PASS_COUNT};
      c.dispatch_indirect(*compact_, {counter, counter, counter}, p, counter, 0);
    });
    ADD_FAILURE() << "arguments in a buffer without the indirect usage";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("BufferUsage::Indirect")) << e.what();
  }
}

}  // namespace
}  // namespace cofusion::test
