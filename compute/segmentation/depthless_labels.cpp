#include "segmentation/depthless_labels.h"

#include <atomic>
#include <cmath>
#include <string>
#include <vector>

#include "common/error.h"
#include "segmentation/parallel.h"

namespace cofusion::segmentation {

void label_depthless_pixels(std::span<uint16_t> labels, const Superpixels& superpixels, const float* depth_m,
                            uint16_t none, std::span<const uint8_t> excluded) {
  const size_t n = static_cast<size_t>(superpixels.width) * static_cast<size_t>(superpixels.height);
  if (labels.size() != n || superpixels.label.size() != n)
    throw Error("label_depthless_pixels: " + std::to_string(labels.size()) + " labels and " +
                std::to_string(superpixels.label.size()) + " superpixel labels for " + std::to_string(n) + " pixels");
  if (n > 0 && !depth_m) throw Error("label_depthless_pixels: no depth image");
  if (!excluded.empty() && excluded.size() != n)
    throw Error("label_depthless_pixels: " + std::to_string(excluded.size()) + " exclusion flags for " +
                std::to_string(n) + " pixels");
  const auto has_depth = [&](size_t i) { return std::isfinite(depth_m[i]) && depth_m[i] > 0.0f; };
  // Per superpixel, over its pixels with depth: the majority candidate (Boyer-Moore), then its votes.
  const size_t count = static_cast<size_t>(superpixels.count);
  std::vector<uint16_t> candidate(count, none);
  std::vector<int> lead(count, 0), with_depth(count, 0);
  for (size_t i = 0; i < n; ++i) {
    if (!has_depth(i)) continue;
    const size_t s = static_cast<size_t>(superpixels.label[i]);
    ++with_depth[s];
    if (lead[s] == 0) candidate[s] = labels[i], lead[s] = 1;
    else lead[s] += candidate[s] == labels[i] ? 1 : -1;
  }
  // The candidates' votes (integer counts) and the fill, in parallel.
  std::vector<std::atomic<int>> votes(count);
  detail::for_range(static_cast<int64_t>(n), 16384, [&](int64_t i0, int64_t i1) {
    for (auto i = static_cast<size_t>(i0); i < static_cast<size_t>(i1); ++i)
      if (has_depth(i) && labels[i] == candidate[size_t(superpixels.label[i])])
        votes[size_t(superpixels.label[i])].fetch_add(1, std::memory_order_relaxed);
  });
  detail::for_range(static_cast<int64_t>(n), 16384, [&](int64_t i0, int64_t i1) {
    for (auto i = static_cast<size_t>(i0); i < static_cast<size_t>(i1); ++i) {
      if (has_depth(i) || labels[i] != none || (!excluded.empty() && excluded[i])) continue;
      const size_t s = static_cast<size_t>(superpixels.label[i]);
      if (candidate[s] != none && 2 * votes[s] > with_depth[s]) labels[i] = candidate[s];
    }
  });
}

}  // namespace cofusion::segmentation
