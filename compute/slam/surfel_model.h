#pragma once
// A surfel model in Vulkan buffers, its prediction into a view (compute splatting) and fusion of
// a live frame into it. Every kernel has a CPU reference in surfel_reference.h.
//
// Thread safety: SurfelPipelines holds only pipelines; every method is const and keeps no state
// between calls, so one instance may serve several threads at once as long as each thread uses
// its own gpu::Stream (or CommandList) and its own SurfelModel. A SurfelModel (its buffers and the
// per-fusion scratch it owns) belongs to one thread at a time. Buffers that are only read (the
// live frame, a label map) may be shared by concurrent calls.
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "common/pixel_rect.h"
#include "common/surfel_cloud.h"
#include "gpu/stream.h"
#include "kernels/compaction.h"
#include "kernels/preprocess.h"
#include "shared/host_device.h"
#include "slam/surfel_params.h"

namespace cofusion::slam {

class SurfelModel {
 public:
  SurfelModel(gpu::Context& ctx, int id, unsigned initial_capacity);

  int id() const { return id_; }
  // Number of surfels (as of the last completed fusion).
  unsigned count() const { return count_; }
  unsigned capacity() const { return capacity_; }
  const gpu::BufferPtr& surfels() const { return surfels_; }
  // Largest model this device can hold in one storage buffer.
  unsigned max_capacity() const { return max_capacity_; }

  // Grows the buffers (doubling) so that `needed` surfels fit, keeping the content. Throws
  // cofusion::Error naming the model when the device cannot hold that many, and
  // gpu::DeviceMemoryError (the model unchanged) when it has no memory for the larger buffers.
  void reserve(gpu::Stream& stream, unsigned needed);

  // Capacity limit. The most surfels this model may hold after a fusion that adds up to
  // `incoming` new ones: `max_surfels` (FusionParams; 0 = no cap of its own) and what the device
  // leaves room for (max_capacity() less incoming).
  unsigned limit(unsigned incoming, unsigned max_surfels) const;
  // Makes room for a fusion adding up to `incoming` surfels: grows the buffers where it can; when
  // the model is over limit(), or the device has no memory to grow it (max_capacity() then drops
  // to the present capacity for good), culls its least confident surfels down to
  // params.cull_keep_fraction of the limit. Returns how many were culled.
  unsigned make_room(gpu::Stream& stream, unsigned incoming, const FusionParams& params);
  // Keeps the `keep` most confident surfels and drops the rest (keep_most_confident); returns how
  // many went. Reads the model back and uploads what stays: host work, done only when a model
  // reaches its limit.
  unsigned cull_least_confident(gpu::Stream& stream, unsigned keep);
  // Surfels culled over the model's life.
  uint64_t culled_total() const { return culled_total_; }

  std::vector<Surfel> download(gpu::Stream& stream) const;
  void upload(gpu::Stream& stream, const std::vector<Surfel>& surfels);

  Eigen::Isometry3d T_world_model = Eigen::Isometry3d::Identity();

 private:
  friend class SurfelPipelines;
  // Allocates (or grows) the per-fusion scratch for a live image of `pixels` pixels and an index
  // map of `index_map_cells` cells.
  void ensure_fusion_scratch(size_t pixels, size_t index_map_cells);
  // The compaction's blocks buffer and keep mask (kernels/compaction.h), grown to cover `elements`.
  const gpu::BufferPtr& compaction_blocks(uint32_t elements);
  const gpu::BufferPtr& compaction_keep_mask(uint32_t elements);

  gpu::Context& ctx_;
  int id_;
  unsigned count_ = 0;
  unsigned capacity_ = 0;
  unsigned max_capacity_ = 0;
  uint64_t culled_total_ = 0;
  gpu::BufferPtr surfels_;  // Surfel[capacity]
  // Cleanup's decided surfels (at their own index, compacted back into surfels_); remove_region's
  // compaction target, swapped with surfels_ after it.
  gpu::BufferPtr scratch_;
  gpu::BufferPtr claim_;    // uint[capacity]: fusion's per-surfel claims, then the merge claims
  gpu::BufferPtr merge_target_;  // uint[capacity]: the surfel each surfel merges into
  gpu::BufferPtr counter_;  // uint[4]
  // The maintenance passes' workgroup counts (IndirectGroups): merge search and claims, cleanup.
  gpu::BufferPtr maintenance_groups_;
  // Per-fusion scratch, owned here (not by SurfelPipelines) so that different models can be fused
  // concurrently; allocated on the first fusion, for the live image size.
  gpu::BufferPtr index_map_;  // uint64 per cell of the supersampled index map
  gpu::BufferPtr assoc_;      // uint per live pixel
  gpu::BufferPtr no_labels_;  // bound in place of a label map when fusing without labels
  gpu::BufferPtr blocks_;     // uint per block of new-surfel pixels or kept surfels (compaction)
  gpu::BufferPtr keep_mask_;  // a bit per surfel: kept by cleanup or remove_region (compaction)
};

// A model rendered into a camera view, as tracking's reference: per pyramid level the vertex
// and normal maps (camera frame), intensity and its gradient; plus the surfel index map.
struct ModelPrediction {
  std::vector<kernels::FramePyramid::Level> levels;  // depth_m unused (null)
  gpu::BufferPtr depth_index;  // uint64 per pixel at level 0
  gpu::BufferPtr index_map;    // uint surfel index per pixel at level 0 (0xFFFFFFFF = none)
  // Level-0 pixels outside this rectangle are empty in every map (gradients: zero beyond one
  // pixel of it at each level); predict() keeps it so, clearing only what the last call wrote.
  PixelRect written;
  static ModelPrediction allocate(gpu::Context& ctx, const Intrinsics& intrinsics, int levels, const std::string& name);
};

// Orders `surfels` so that the `keep` most confident come first (ties: the most recently seen,
// then the most recently created) and drops the rest; the order of those kept is not preserved.
void keep_most_confident(std::vector<Surfel>& surfels, size_t keep);

struct FusionStats {
  unsigned surfels_before = 0;        // when fusion started (after a cull that made room)
  unsigned surfels_after_fusion = 0;  // including new ones
  unsigned surfels_after_cleanup = 0;
  // Culled for the model's capacity limit (SurfelModel::make_room), before fusion and after
  // cleanup; the model's count is then surfels_after_cleanup less the culls after it.
  unsigned culled = 0;
};

class SurfelPipelines {
 public:
  SurfelPipelines(gpu::Context& ctx, const kernels::Preprocessor& preprocessor);

  // Renders `model` seen from a camera at T_camera_model into `out` (all levels). With `rect`
  // (level-0 pixels) only that part of the view is rendered and everything else is empty: the
  // maps equal a whole-view prediction in which no surfel lands outside the rectangle, at the
  // cost of the rectangle and of the last call's rectangle instead of the view.
  void predict(gpu::CommandList& cmd, const SurfelModel& model, const Eigen::Isometry3d& T_camera_model,
               ModelPrediction& out, const PredictionParams& params, int frame,
               const std::optional<PixelRect>& rect = std::nullopt) const;

  // Fuses the live frame (level 0 of `live`) into `model` seen at T_camera_model, then merges
  // duplicate surfels (FusionParams::merge_*) and removes unstable and free-space surfels. Keeps the model within its capacity limit
  // (SurfelModel::make_room: least confident surfels culled before fusion when there is no room,
  // and after cleanup when the count is over the limit). With `labels` (uint per pixel), only pixels whose label is
  // `label` or one of `also_labels` (bit l for label l < 32) are fused. With `rect` (level-0
  // pixels), only pixels in it are fused: with labels it must hold every pixel so labelled, and
  // then the result is the same, at the cost of the
  // rectangle instead of the image. The live colour is multiplied by `colour_gain` (the frame's
  // exposure against the model's, from tracking). Synchronous: returns when the model's new count
  // is known.
  FusionStats fuse(gpu::Stream& stream, SurfelModel& model, const kernels::FramePyramid& live,
                   const Eigen::Isometry3d& T_camera_model, int frame, const FusionParams& params,
                   const gpu::BufferPtr& labels = nullptr, unsigned label = 0,
                   const std::optional<PixelRect>& rect = std::nullopt, float colour_gain = 1.0f,
                   uint32_t also_labels = 0) const;

  // Removes every surfel of `model` (seen at T_camera_model) that projects onto a live pixel whose
  // label (`labels`: uint per level-0 pixel of `live`) is `label` and that lies in front of or at
  // the live surface there: z_surfel < d * (1 + margin_rel), d the live depth (level 0, metres;
  // pixels without depth remove nothing). Surfels behind it (occluded background) stay. Co-Fusion
  // uses this to take a newly moving object out of the background model. Synchronous, like fuse();
  // returns the number of surfels removed. Throws cofusion::Error on a missing or short buffer.
  unsigned remove_region(gpu::Stream& stream, SurfelModel& model, const kernels::FramePyramid& live,
                         const Eigen::Isometry3d& T_camera_model, const gpu::BufferPtr& labels, unsigned label,
                         float margin_rel) const;

  // Single kernels, as predict() and fuse() record them (for tests against the references).
  struct FuseBuffers {
    gpu::BufferPtr surfels, index_map, vertex, normal, rgb, assoc, claim, counter, labels;
    gpu::BufferPtr blocks;  // update: CompactionScan::blocks_bytes(rectangle's pixels)
  };
  void splat(gpu::CommandList& cmd, const gpu::BufferPtr& surfels, const gpu::BufferPtr& grid,
             const gpu_layout::SplatParams& p) const;
  void resolve(gpu::CommandList& cmd, const gpu::BufferPtr& surfels, const gpu::BufferPtr& depth_index,
               const kernels::FramePyramid::Level& out, const gpu::BufferPtr& index_map,
               const gpu_layout::ResolveParams& p) const;
  // The resolve writes p's [x0, x1) x [y0, y1); the subsample `rect` of dst (default: all).
  void subsample(gpu::CommandList& cmd, const kernels::FramePyramid::Level& src, const kernels::FramePyramid::Level& dst,
                 const std::optional<PixelRect>& rect = std::nullopt) const;
  void associate(gpu::CommandList& cmd, const FuseBuffers& b, const gpu_layout::FuseParams& p) const;
  // fuse_count_new, compaction_scan and fuse_update: new surfels from counter[0] on, in pixel order.
  void update(gpu::CommandList& cmd, const FuseBuffers& b, const gpu_layout::FuseParams& p) const;
  struct MergeBuffers {
    gpu::BufferPtr surfels, index_map, target, claim, counter, labels;  // labels: any buffer without use_labels
  };
  // The maintenance passes after fusion (merge search, claims, cleanup) run over the model's
  // surfels including fusion's new ones, min(counter[0], bound), a count only the GPU knows:
  // maintenance_groups() records their workgroup counts for it into `groups`
  // (kernels::IndirectGroups::kBytes), and they are dispatched indirectly from there, so that no
  // workgroup runs past the count (the host's bound, one new surfel per fused pixel, is mostly
  // idle). `bound` is the passes' p.surfel_count.
  void maintenance_groups(gpu::CommandList& cmd, const gpu::BufferPtr& counter, uint32_t bound,
                          const gpu::BufferPtr& groups) const;
  void merge_select(gpu::CommandList& cmd, const MergeBuffers& b, const gpu_layout::MergeParams& p,
                    const gpu::BufferPtr& groups) const;
  void merge_claim(gpu::CommandList& cmd, const MergeBuffers& b, const gpu_layout::MergeParams& p,
                   const gpu::BufferPtr& groups) const;
  // cleanup and remove_region: the deciding (counting) pass, compaction_scan and surfel_compact,
  // which copies the kept surfels, in their order, from counter[1] on (the caller sets it, usually
  // to 0). `blocks`: CompactionScan::blocks_bytes(p.surfel_count); `keep_mask`:
  // CompactionScan::keep_mask_bytes(p.surfel_count).
  // cleanup decides each surfel of `surfels` once, writes the kept ones as they stay (merged,
  // penalised) to `scratch` at their own index, and compacts them from there back into `surfels`.
  // With p.merge, `merge_target` and `merge_claim` are merge_select's and merge_claim's results;
  // without, they are not read (null binds `surfels` in their place). Its workgroups come from
  // `groups` (maintenance_groups()).
  void cleanup(gpu::CommandList& cmd, const gpu::BufferPtr& surfels, const gpu::BufferPtr& scratch,
               const gpu::BufferPtr& depth_m, const gpu::BufferPtr& counter, const gpu::BufferPtr& blocks,
               const gpu::BufferPtr& keep_mask, const gpu_layout::CleanupParams& p, const gpu::BufferPtr& groups,
               const gpu::BufferPtr& merge_target = nullptr, const gpu::BufferPtr& merge_claim = nullptr) const;
  // remove_region copies the kept surfels of `src` (unchanged) to `dst`.
  void remove_region(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst,
                     const gpu::BufferPtr& depth_m, const gpu::BufferPtr& labels, const gpu::BufferPtr& counter,
                     const gpu::BufferPtr& blocks, const gpu::BufferPtr& keep_mask,
                     const gpu_layout::RemoveRegionParams& p) const;

 private:
  // After a counting pass over `block_count` blocks: compaction_scan into counter[1], then
  // surfel_compact copies the kept surfels from src to dst. With `groups` (maintenance_groups()),
  // the counting pass ran over the blocks of counter[0]'s surfels only, and so do both.
  void compact_kept(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst,
                    const gpu::BufferPtr& counter, const gpu::BufferPtr& blocks, const gpu::BufferPtr& keep_mask,
                    uint32_t block_count, const gpu::BufferPtr& groups = nullptr) const;

  const kernels::Preprocessor& preprocessor_;
  gpu::ComputePipeline splat_;
  gpu::ComputePipeline resolve_;
  gpu::ComputePipeline subsample_;
  kernels::CompactionScan scan_;
  kernels::IndirectGroups groups_;
  gpu::ComputePipeline associate_;
  gpu::ComputePipeline count_new_;
  gpu::ComputePipeline update_;
  gpu::ComputePipeline merge_select_;
  gpu::ComputePipeline merge_claim_;
  gpu::ComputePipeline cleanup_;
  gpu::ComputePipeline remove_region_;
  gpu::ComputePipeline compact_;
};

// Row-major float 3x4 of a rigid transform, as the shaders take it.
void to_rows(const Eigen::Isometry3d& T, float out[12]);

}  // namespace cofusion::slam
