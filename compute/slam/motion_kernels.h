#pragma once
// GPU kernels of Co-Fusion's multi-model loop that sit between tracking and segmentation:
//  - live-vertex masking (shaders/mask_vertices.comp): each model is tracked only with the live
//    points the previous segmentation labelled as that model;
//  - motion residuals (shaders/motion_residual.comp): the per-pixel alignment cost of the live
//    frame against one model after tracking, which the segmentation's unaries take.
// CPU references: slam/motion_reference.h.
//
// Thread safety: MotionKernels holds only pipelines and every method is const and records into
// the caller's CommandList; one instance may serve several threads (each with its own stream).
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/pixel_rect.h"
#include "gpu/stream.h"
#include "kernels/preprocess.h"
#include "shared/host_device.h"

namespace cofusion::slam {

class MotionKernels {
 public:
  explicit MotionKernels(gpu::Context& ctx);

  // dst_vertex = src_vertex (vec4 per pixel of a pyramid level of level_width x level_height)
  // where the label of level-0 pixel (x << level, y << level) (`labels`: uint per pixel of
  // level0_width x level0_height; 0..31 a model slot, >= 32 none) has its bit set in keep_mask;
  // vec4(0) (invalid) elsewhere. The level size must be level 0's halved `level` times (as
  // Intrinsics::at_level). With `rect` (pixels of this level), only pixels in it are written
  // and the rest of dst keeps its content. Throws cofusion::Error on mismatched sizes or short
  // buffers.
  void mask_vertices(gpu::CommandList& cmd, const gpu::BufferPtr& src_vertex, const gpu::BufferPtr& dst_vertex,
                     const gpu::BufferPtr& labels, int level_width, int level_height, int level0_width,
                     int level0_height, int level, uint32_t keep_mask,
                     const std::optional<PixelRect>& rect = std::nullopt) const;

  // mask_vertices for every level: masked[l].vertex from live[l].vertex (no barrier recorded).
  // `masked` as made by allocate_masked_levels(live). With `rect_level0`, each level writes only
  // rect_level0.at_level(l): Tracker::track with the same rectangle reads nothing else.
  void mask_levels(gpu::CommandList& cmd, const std::vector<kernels::FramePyramid::Level>& live,
                   const std::vector<kernels::FramePyramid::Level>& masked, const gpu::BufferPtr& labels,
                   uint32_t keep_mask, const std::optional<PixelRect>& rect_level0 = std::nullopt) const;

  // Levels to hand to Tracker::track for one model: the live levels (sharing their depth, normal,
  // intensity and gradient buffers) with a vertex buffer of their own, for mask_levels to fill.
  static std::vector<kernels::FramePyramid::Level> allocate_masked_levels(
      gpu::Context& ctx, const std::vector<kernels::FramePyramid::Level>& live, const std::string& name);

  // Per live pixel of `live` (level 0: vertex, intensity) against the model's predicted
  // `reference` maps (vertex, normal, intensity in the reference camera frame, same size and
  // intrinsics), at T_reference_live (reference point = T * live point), into `out`
  // (vec4 per pixel; layout in shared/host_device.h, MotionResidualParams). With `rect`, only
  // live pixels in it are written. The live intensity is multiplied by `live_intensity_gain` (the
  // tracking's exposure gain). Throws cofusion::Error on mismatched sizes or missing / short
  // buffers.
  void residuals(gpu::CommandList& cmd, const kernels::FramePyramid::Level& live,
                 const kernels::FramePyramid::Level& reference, const Eigen::Isometry3d& T_reference_live,
                 const gpu::BufferPtr& out, const std::optional<PixelRect>& rect = std::nullopt,
                 double live_intensity_gain = 1.0) const;

  // The raw kernel, as residuals() records it (for the GPU-vs-CPU tests).
  void residuals(gpu::CommandList& cmd, const gpu::BufferPtr& live_vertex, const gpu::BufferPtr& live_intensity,
                 const gpu::BufferPtr& ref_vertex, const gpu::BufferPtr& ref_normal, const gpu::BufferPtr& ref_intensity,
                 const gpu::BufferPtr& out, const gpu_layout::MotionResidualParams& p) const;

 private:
  gpu::ComputePipeline mask_vertices_;
  gpu::ComputePipeline motion_residual_;
};

}  // namespace cofusion::slam
