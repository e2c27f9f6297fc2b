#pragma once
// Does a new model's motion show in what the camera sees? A static surface that the tracker
// constrains only partly (a far wall patch, tracked by its plane alone, slides along it) can
// travel as far as a moving object while its pixels show exactly what they showed when it was
// spawned. Points sampled from the spawn frame's region (world frame, with their intensity) are
// compared with the current frame twice: where the model's tracked motion since the spawn puts
// them, and where they were (no motion relative to the background). A moving object's points are
// explained by its motion and not by standing still; an unobservable drift explains both alike.
// The same test runs backwards, the model's current pixels against the spawn frame: an object
// that slides along its own texture-poor length (an arm reaching in) looks the same at its old
// points, but its current pixels beyond where it ended then showed what lay behind it.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "common/intrinsics.h"

namespace cofusion::slam {

struct ObservedMotionParams {
  // New models spawned by motion keep this many of their region's pixels as test points (0 turns
  // the test off).
  int points = 400;
  // A point is explained where its projection's live depth lies within this many depth-noise
  // standard deviations (shared/depth_noise.h, at the point's depth) of the point's depth ...
  float depth_sigmas = 3.0f;
  // ... and its intensity (grey in [0, 1], after the frames' gain: the ratio of the mean
  // intensities of the points the motion explains in depth) within this of the live pixel's.
  float max_intensity_diff = 0.1f;
  // A model's motion shows when standing still explains at most this fraction of what its motion
  // explains (shares of the points both put in view) ...
  double max_still_ratio = 0.6;
  // ... and at least this share of the points was in view for both (else nothing is decided):
  // the motion was tracked to fit the model's pixels while standing still carries the camera's
  // error, so a ratio over the few points a camera's pan leaves in view where they were (at the
  // image's border, where depth is least reliable) is too weak a basis.
  double min_counted = 0.4;
};

struct ObservedPoint {
  Eigen::Vector3f p_world;
  float intensity;  // grey in [0, 1]
};

// Up to `count` points of the region's pixels (spread evenly over `pixels`, row-major indices)
// that have depth, in the world frame of the camera pose T_world_camera.
std::vector<ObservedPoint> sample_region_points(const std::vector<size_t>& pixels, const float* depth_m,
                                                const uint8_t* rgb, const Intrinsics& intrinsics,
                                                const Eigen::Isometry3d& T_world_camera, int count);

// Of the points that both hypotheses put in view on a pixel with depth and not behind the live
// surface (a share `counted` of all):
// the share explained after the motion and the share explained where they were.
struct ObservedShares {
  double moved = 0.0;
  double still = 0.0;
  double counted = 0.0;
};

// Shares of `points` the current frame (depth_m, rgb seen from T_world_camera) explains after the
// world-frame motion `motion_world` (p -> motion_world * p) and without it.
ObservedShares observed_shares(const std::vector<ObservedPoint>& points, const Eigen::Isometry3d& motion_world,
                               const float* depth_m, const uint8_t* rgb, const Intrinsics& intrinsics,
                               const Eigen::Isometry3d& T_world_camera, const ObservedMotionParams& params);

// Whether the shares show the motion (ObservedMotionParams::max_still_ratio, min_counted).
bool motion_shows(const ObservedShares& shares, const ObservedMotionParams& params);

// What a new model's spawn frame holds for the test: its region's points and the frame itself.
struct SpawnEvidence {
  std::vector<ObservedPoint> points;
  std::vector<float> depth_m;
  std::vector<uint8_t> rgb;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
};

SpawnEvidence record_spawn(const std::vector<size_t>& region_pixels, const float* depth_m, const uint8_t* rgb,
                           const Intrinsics& intrinsics, const Eigen::Isometry3d& T_world_camera,
                           const ObservedMotionParams& params);

// Whether the model's world-frame motion since its spawn shows in the current frame (depth_m,
// rgb, T_world_camera; the model's pixels in it `current_pixels`): forwards (the spawn points in
// the current frame) or backwards (the current pixels' points in the spawn frame).
bool motion_observed(const SpawnEvidence& spawn, const std::vector<size_t>& current_pixels,
                     const Eigen::Isometry3d& motion_world, const float* depth_m, const uint8_t* rgb,
                     const Intrinsics& intrinsics, const Eigen::Isometry3d& T_world_camera,
                     const ObservedMotionParams& params);

}  // namespace cofusion::slam
