#pragma once
// CPU references of the surfel kernels (splat_surfels, splat_resolve, subsample_prediction,
// fuse_associate, fuse_update, surfel_merge_select, surfel_merge_claim, surfel_cleanup,
// surfel_remove_region), taking the same parameter structs as the shaders.
// Sequential loops: "atomic" minima and appends happen in index order, so results are
// deterministic; the GPU's new and kept surfels come in the same order (a stable compaction).
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec4.hpp>
#include <vector>

#include "common/surfel_cloud.h"
#include "kernels/image.h"
#include "shared/host_device.h"

namespace cofusion::slam::reference {

using kernels::Image;

// Key grid of splat_surfels: width*height uint64 (all ones = empty).
std::vector<uint64_t> splat(const std::vector<Surfel>& surfels, const gpu_layout::SplatParams& p);

struct PredictedMaps {
  Image<glm::vec4> vertex, normal;
  Image<float> intensity;
  Image<uint32_t> index;
};
// The whole view: pixels outside p's area are empty (p's x0..y1 only bound the GPU's writes).
PredictedMaps resolve(const std::vector<Surfel>& surfels, const std::vector<uint64_t>& depth_index,
                      const gpu_layout::ResolveParams& p);
PredictedMaps subsample(const PredictedMaps& src);

struct LiveMaps {
  Image<glm::vec4> vertex, normal;
  std::vector<uint8_t> rgb;       // width*height*3
  std::vector<uint32_t> labels;   // empty = no labels
};
struct Association {
  std::vector<uint32_t> assoc;  // per pixel
  std::vector<uint32_t> claim;  // per surfel
};
// Pixels outside p's rectangle are FUSE_SKIP_PIXEL.
Association associate(const std::vector<Surfel>& surfels, const std::vector<uint64_t>& index_map, const LiveMaps& live,
                      const gpu_layout::FuseParams& p);
// Updates `surfels` in place and appends new ones (in pixel order).
void update(std::vector<Surfel>& surfels, const Association& a, const LiveMaps& live, const gpu_layout::FuseParams& p);
// surfel_merge_select: per surfel (up to p.surfel_count) the surfel it merges into, MERGE_NONE
// for none. `index_map`: the fusion's supersampled key grid; `labels`: uint per live pixel (read
// when p.use_labels).
std::vector<uint32_t> merge_select(const std::vector<Surfel>& surfels, const std::vector<uint64_t>& index_map,
                                   const std::vector<uint32_t>& labels, const gpu_layout::MergeParams& p);
// surfel_merge_claim: per surfel the lowest source merging into it (MERGE_NONE: none).
std::vector<uint32_t> merge_claim(const std::vector<uint32_t>& target);
struct Merges {
  std::vector<uint32_t> target, claim;  // per surfel, as merge_select and merge_claim give them
};
// Surfels kept by surfel_cleanup, in index order; with p.merge, `merges` are applied first.
std::vector<Surfel> cleanup(const std::vector<Surfel>& surfels, const Image<float>& depth_m,
                            const gpu_layout::CleanupParams& p, const Merges& merges = {});
// shared/surfel_merge.glsl: `kept` absorbs `merged`.
Surfel merge_surfels(const Surfel& kept, const Surfel& merged);

// Surfels kept by surfel_remove_region, in index order. `labels`: uint per live pixel.
std::vector<Surfel> remove_region(const std::vector<Surfel>& surfels, const Image<float>& depth_m,
                                  const std::vector<uint32_t>& labels, const gpu_layout::RemoveRegionParams& p);

}  // namespace cofusion::slam::reference
