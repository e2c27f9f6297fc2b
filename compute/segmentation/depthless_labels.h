#pragma once
// Labels for pixels the sensor gave no depth: the segmentation decides only where there is
// geometry, but an object's image extent includes its depth dropouts (grazing faces, edges).
#include <cstdint>
#include <span>

#include "segmentation/slic.h"

namespace cofusion::segmentation {

// Each pixel without depth (depth_m 0 or not finite) that is `none` in `labels` takes the label
// that more than half of its superpixel's pixels with depth carry, where that label is not `none`
// (so a superpixel mostly of unassigned or excluded pixels gives nothing). Pixels with depth, and
// those non-zero in `excluded` (a person's, say; empty: none), are left as they are. labels,
// depth_m and excluded: superpixels.width * superpixels.height, row-major.
void label_depthless_pixels(std::span<uint16_t> labels, const Superpixels& superpixels, const float* depth_m,
                            uint16_t none, std::span<const uint8_t> excluded = {});

}  // namespace cofusion::segmentation
