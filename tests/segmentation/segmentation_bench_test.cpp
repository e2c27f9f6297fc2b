// Timing print of every segmentation step (not an assertion on speed: machines differ).
#include <gtest/gtest.h>

#include <cstdio>

#include "segmentation/segmentation_bench.h"

namespace cofusion::segmentation {
namespace {

TEST(SegmentationBench, PrintsStepTimings) {
  for (const CrfMethod method : {CrfMethod::kExact, CrfMethod::kPermutohedral}) {
    for (const int size : {32, 16, 8}) {
      SegmentationBenchConfig config;
      config.superpixel_size_px = size;
      config.crf_method = method;
      config.repeats = 3;
      const SegmentationBenchTimings t = bench_segmentation(config);
      std::printf("640x480 %s S=%2d: %4d superpixels (%4d CRF nodes): slic %.1f ms, CRF nodes %.1f ms, unary %.1f ms, crf %.1f ms, post %.1f ms, total %.1f ms\n",
                  method == CrfMethod::kExact ? "exact        " : "permutohedral", size, t.superpixels, t.crf_nodes,
                  t.slic_ms, t.prepare_ms, t.unary_ms, t.crf_ms, t.post_ms, t.total_ms);
      EXPECT_GT(t.superpixels, 0);
      EXPECT_GT(t.crf_nodes, 0);
    }
  }
}

}  // namespace
}  // namespace cofusion::segmentation
