#pragma once
// CPU reference of tracking: the per-iteration sums of shaders/icp_rgb_reduce.comp computed by a
// plain loop in double over host copies of the maps, and a CPU-only track() that runs the same
// Gauss-Newton loop (tracker_solver.h) on them. Written independently of the shader, for tests.
#include <optional>
#include <span>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec4.hpp>

#include "common/intrinsics.h"
#include "common/pixel_rect.h"
#include "gpu/stream.h"
#include "kernels/image.h"
#include "kernels/preprocess.h"
#include "slam/tracker_solver.h"

namespace cofusion::slam::reference {

// Host copy of the maps of one pyramid level that tracking reads.
struct HostLevel {
  Intrinsics intrinsics;
  kernels::Image<glm::vec4> vertex;  // metres, w = 1 valid
  kernels::Image<glm::vec4> normal;  // w = 1 valid
  kernels::Image<float> intensity;   // [0, 255]
  kernels::Image<glm::vec2> gradient;  // per pixel, [0, 255] units
  kernels::Image<float> depth_m;       // metres, 0 = none (never masked); empty for a level without depth
};

// Downloads the vertex, normal, intensity, gradient and depth maps of `level` (synchronous).
HostLevel download_level(gpu::Stream& stream, const kernels::FramePyramid::Level& level);
std::vector<HostLevel> download_levels(gpu::Stream& stream, const std::vector<kernels::FramePyramid::Level>& levels);

// The sums of one iteration at pose T_reference_live (same definition as the GPU reduction).
// `rect`: only live pixels in it take part (none = all). `scales`: residuals beyond its Huber
// thresholds get weight delta / |r| (0 = none); the live intensity is multiplied by its gain.
// `tile_weights`: Tracker::set_photometric_tile_weights' weights, read where
// params.photometric_tile_weights (empty = all 1).
LinearSystemSums compute_sums(const HostLevel& live, const HostLevel& reference,
                              const Eigen::Isometry3d& T_reference_live, const TrackerParams& params,
                              const std::optional<PixelRect>& rect = std::nullopt, const IterationScales& scales = {},
                              std::span<const float> tile_weights = {});

// Coarse-to-fine tracking on the CPU; same contract as Tracker::track.
TrackingResult track(const std::vector<HostLevel>& live, const std::vector<HostLevel>& reference,
                     const Eigen::Isometry3d& T_reference_live_guess, const TrackerParams& params);

}  // namespace cofusion::slam::reference
