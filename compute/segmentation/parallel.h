#pragma once
// Small parallel helpers for the segmentation code. Work that sums floating-point values is split
// into a FIXED number of chunks whose partial results are combined in chunk order, so the result
// does not depend on how many threads TBB happens to use or how it schedules them.
#include <algorithm>
#include <chrono>
#include <cstdint>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

namespace cofusion::segmentation::detail {

// Calls fn(chunk, begin, end) for `chunks` contiguous, nearly equal slices of [0, n), in parallel.
// Chunk boundaries depend only on n and chunks.
template <class Fn>
void for_fixed_chunks(int64_t n, int chunks, Fn&& fn) {
  chunks = static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(chunks, n)));
  auto bound = [&](int c) { return n * c / chunks; };
  tbb::parallel_for(
      tbb::blocked_range<int>(0, chunks, 1),
      [&](const tbb::blocked_range<int>& r) {
        for (int c = r.begin(); c != r.end(); ++c) fn(c, bound(c), bound(c + 1));
      },
      tbb::simple_partitioner());
}

// Calls fn(begin, end) over [0, n) in parallel with grain `grain` (for work with no reductions).
template <class Fn>
void for_range(int64_t n, int64_t grain, Fn&& fn) {
  if (n <= 0) return;
  if (n <= grain) {
    fn(int64_t{0}, n);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, n, std::max<int64_t>(1, grain)),
                    [&](const tbb::blocked_range<int64_t>& r) { fn(r.begin(), r.end()); });
}

inline double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace cofusion::segmentation::detail
