#pragma once
// Frame-to-model tracking (Co-Fusion section "Tracking active models", after ElasticFusion):
// the live frame is registered against the model's predicted view at time t-1 by minimising
//   E = E_icp + lambda * E_rgb
// with point-to-plane ICP (eq. 2) and photometric alignment (eq. 3), Gauss-Newton on a 4-level
// pyramid, coarse to fine. One GPU dispatch per iteration reduces both linear systems
// (shaders/icp_rgb_reduce.comp); the 6x6 solve runs on the host in double.
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "common/pixel_rect.h"
#include "gpu/stream.h"
#include "kernels/preprocess.h"
#include "slam/tracker_solver.h"

namespace cofusion::slam {

// Thread safety: a Tracker may be used by one thread at a time (it owns one partial-sums buffer).
class Tracker {
 public:
  // Throws cofusion::Error when the device lacks subgroup arithmetic or has subgroups smaller
  // than 4 invocations (the shader's shared memory holds at most 64 subgroups of a workgroup).
  Tracker(gpu::Context& ctx, TrackerParams params);

  // Estimates T_reference_live, which maps live-camera points into the reference camera frame.
  // `live`: the live frame's pyramid (vertex, normal, intensity of each level; see
  // kernels::FramePyramid). `reference`: the model's predicted view in the reference (t-1) camera
  // frame, with vertex, normal, intensity and gradient maps per level, same sizes and intrinsics.
  // Levels beyond params().iterations_per_level.size() are not allowed; all levels given are used.
  // On failure (result.failed) the returned pose is the guess. Synchronous: waits for the GPU.
  // Throws cofusion::Error on mismatched levels, missing buffers or a non-finite guess.
  // `rect_level0`: only live pixels in this rectangle of level 0 (and its counterpart on each
  // level, PixelRect::at_level) take part; none = every pixel. The reference is read anywhere.
  TrackingResult track(gpu::Stream& stream, const std::vector<kernels::FramePyramid::Level>& live,
                       const std::vector<kernels::FramePyramid::Level>& reference,
                       const Eigen::Isometry3d& T_reference_live_guess,
                       const std::optional<PixelRect>& rect_level0 = std::nullopt);

  // The sums of one Gauss-Newton iteration at one level, at pose T_reference_live (what track()
  // computes per iteration; exposed for the GPU-vs-CPU tests).
  // `rect`: live pixels of this level that take part (none = all; clamped to the level).
  // `scales`: residuals beyond its Huber thresholds are down-weighted (0 = none); the live
  // intensity is multiplied by its gain.
  LinearSystemSums compute_sums(gpu::Stream& stream, const kernels::FramePyramid::Level& live,
                                const kernels::FramePyramid::Level& reference,
                                const Eigen::Isometry3d& T_reference_live,
                                const std::optional<PixelRect>& rect = std::nullopt, const IterationScales& scales = {});

  const TrackerParams& params() const { return params_; }
  void set_params(const TrackerParams& params);
  // The weights of the live image's tiles (ICP_RGB_TILES_X x ICP_RGB_TILES_Y, row-major, each >= 0)
  // for the trackings that follow, where params().photometric_tile_weights. Not while a recorded
  // reduction of this tracker is pending. Throws cofusion::Error on a wrong count or weight.
  void set_photometric_tile_weights(std::span<const float> weights);

  // compute_sums in three steps, for several trackers in one submission (track_together):
  // record_reduction records the reduction, record_readback (after it, in the same list) where
  // the host will find its partial sums, and add_partials sums them once the list has completed.
  uint32_t record_reduction(gpu::CommandList& cmd, const kernels::FramePyramid::Level& live,
                            const kernels::FramePyramid::Level& reference, const Eigen::Isometry3d& T_reference_live,
                            const std::optional<PixelRect>& rect, const IterationScales& scales);
  const float* record_readback(gpu::CommandList& cmd, uint32_t groups);
  static LinearSystemSums add_partials(const float* partials, uint32_t groups);
  // Throws cofusion::Error unless track() could run with these inputs.
  void check_inputs(const std::vector<kernels::FramePyramid::Level>& live,
                    const std::vector<kernels::FramePyramid::Level>& reference,
                    const Eigen::Isometry3d& T_reference_live_guess, const std::string& what) const;

 private:
  gpu::Context& ctx_;
  TrackerParams params_;
  gpu::ComputePipeline reduce_;
  // The reduction with reweighted photometric residuals (TrackerParams::photometric_gradient_c,
  // photometric_cauchy_k), created when first needed.
  std::optional<gpu::ComputePipeline> reduce_reweighted_;
  gpu::BufferPtr partials_;
  // set_photometric_tile_weights' weights: on the host, and the buffer the reweighted kernel reads
  // (uploaded by the next reduction when `tile_weights_changed_`).
  std::vector<float> tile_weights_;
  gpu::BufferPtr tile_weights_buffer_, tile_weights_staging_;
  bool tile_weights_changed_ = true;
  // Where the host reads the partial sums when partials_ is not mapped (a discrete GPU).
  gpu::BufferPtr partials_readback_;
};

// One tracking of track_together: Tracker::track's inputs and its result.
struct TrackingJob {
  Tracker* tracker = nullptr;  // a different one for every job of a call
  const std::vector<kernels::FramePyramid::Level>* live = nullptr;
  const std::vector<kernels::FramePyramid::Level>* reference = nullptr;
  Eigen::Isometry3d T_reference_live_guess = Eigen::Isometry3d::Identity();
  std::optional<PixelRect> rect_level0;
  std::string profile_group;  // the kernel profile's group for its reductions; empty = the stream's
  // Gauss-Newton iterations per level for this job instead of the tracker's
  // TrackerParams::iterations_per_level (at least one entry per live level); the tracker is not changed.
  std::optional<std::vector<int>> iterations_per_level;
  TrackingResult result;  // set by track_together
};

// Tracker::track for every job at once, with the same results: the jobs' Gauss-Newton loops
// advance in lockstep, each round one submission on `stream` that reduces every unfinished job's
// next iteration, and one wait. A tracking costs about 20 round trips; on a discrete GPU a round
// trip, not the reduction, is most of an iteration's time, so N models cost about what one does.
// The first submission waits for `waits` (the work that wrote the jobs' maps on other streams).
// Throws cofusion::Error on a job's bad inputs (as Tracker::track) or a tracker used twice.
void track_together(gpu::Stream& stream, std::span<TrackingJob> jobs, std::span<const gpu::TimelinePoint> waits = {});

// Throws cofusion::Error unless `live` and `reference` have the same, non-zero number of levels
// with equal sizes and the buffers every level needs. `what` names the caller in messages.
void check_levels(const std::vector<kernels::FramePyramid::Level>& live,
                  const std::vector<kernels::FramePyramid::Level>& reference, const std::string& what);

}  // namespace cofusion::slam
