#pragma once
// Internal to CoFusion (co_fusion.cpp, lifecycle.cpp): a model's state and the label slots.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "common/se3.h"
#include "slam/co_fusion.h"

namespace cofusion::slam::internal {

constexpr uint8_t kNoSlot = 255;  // no model: no depth, or a model's pixel it cannot explain
constexpr int kSlots = 32;        // the label masks are 32-bit
// Pixels no model claims although they have depth (outliers that spawned nothing, components the
// segmentation removed): nobody fuses them, but the background still tracks with them, so that a
// burst of outliers (fast camera motion) cannot starve the camera's tracking.
constexpr uint8_t kUnclaimedSlot = kSlots - 1;
// Pixels of a non-rigid mover (LifecycleParams::mover_min_overlap): nobody fuses or tracks them.
constexpr uint8_t kMoverSlot = kSlots - 2;
// Model::slot of a model without a label slot: inactive, or merged away / deleted (pruned from the
// list after the lifecycle step).
constexpr int kInactiveSlot = -1;
constexpr int kRemovedSlot = -2;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

inline double rotation_deg(const Eigen::Isometry3d& T) { return rotation_angle_rad(T) * 180.0 / M_PI; }

// Grey level in [0, 1] of pixel i of an RGB8 image (the mean of its channels, as rgb_to_intensity).
inline float grey_level(const uint8_t* rgb, size_t i) {
  return float(int(rgb[3 * i]) + int(rgb[3 * i + 1]) + int(rgb[3 * i + 2])) * (1.0f / (3.0f * 255.0f));
}

// Surfels of one model expressed in another frame: T_to_from maps positions, its rotation normals.
inline void transform_surfels(std::vector<Surfel>& surfels, const Eigen::Isometry3d& T_to_from) {
  const Eigen::Matrix3f R = T_to_from.rotation().cast<float>();
  const Eigen::Vector3f t = T_to_from.translation().cast<float>();
  for (Surfel& s : surfels) {
    const Eigen::Vector3f p = R * Eigen::Vector3f(s.px, s.py, s.pz) + t;
    const Eigen::Vector3f n = R * Eigen::Vector3f(s.nx, s.ny, s.nz);
    s.px = p.x(), s.py = p.y(), s.pz = p.z();
    s.nx = n.x(), s.ny = n.y(), s.nz = n.z();
  }
}

// Where a model's surfels are: their mean and the distance from it within which 90% of them lie
// (model frame, metres; at least 5 cm).
struct SurfelExtent {
  Eigen::Vector3d centre_model = Eigen::Vector3d::Zero();
  double radius_m = 0;
};
inline SurfelExtent surfel_extent(const std::vector<Surfel>& surfels) {
  SurfelExtent e;
  if (surfels.empty()) return e;
  for (const Surfel& s : surfels) e.centre_model += Eigen::Vector3d(s.px, s.py, s.pz);
  e.centre_model /= double(surfels.size());
  std::vector<double> d;
  d.reserve(surfels.size());
  for (const Surfel& s : surfels) d.push_back((Eigen::Vector3d(s.px, s.py, s.pz) - e.centre_model).norm());
  const auto at = d.begin() + std::ptrdiff_t(d.size() * 9 / 10);
  std::nth_element(d.begin(), at, d.end());
  e.radius_m = std::max(0.05, at == d.end() ? d.back() : *at);
  return e;
}

// Of `pixels`, the share whose background cost is above max_cost_m, among those the background's
// prediction covers (cost not NaN); nullopt when it covers fewer than half of them.
std::optional<double> background_unexplained_share(const std::vector<float>& background_costs,
                                                   const std::vector<size_t>& pixels, float max_cost_m);

// Of the pixels with a model or an outlier label (not kNoSlot, not kMoverSlot), the share whose
// background cost is above max_cost_m among those the background's prediction covers (0: none).
double scene_unexplained_share(const std::vector<float>& background_costs, const std::vector<uint8_t>& slots,
                               float max_cost_m);

// Whether any of `pixels` (indices into a width x height image) has a pixel of `slots` equal to
// `slot` within reach_px along its row or its column (the pixel itself not counted).
bool within_reach_of_slot(const std::vector<size_t>& pixels, const std::vector<uint8_t>& slots, int width, int height,
                          uint8_t slot, int reach_px);

}  // namespace cofusion::slam::internal

namespace cofusion::slam {

struct CoFusion::Model {
  Model(gpu::Context& ctx, const Intrinsics& intrinsics, const CoFusionParams& p,
        const std::vector<kernels::FramePyramid::Level>& live, int id_, int slot_, int frame)
      : id(id_),
        slot(slot_),
        stream(ctx, static_cast<uint32_t>(slot_ + 1), "model " + std::to_string(id_)),
        surfels(ctx, id_, id_ == 0 ? p.slam.fusion.initial_capacity : std::max(1u << 16, p.slam.fusion.initial_capacity / 8)),
        prediction(ModelPrediction::allocate(ctx, intrinsics, p.slam.preprocess.pyramid_levels,
                                             "model " + std::to_string(id_) + " prediction")),
        tracker(ctx, tracker_params(p, id_)),
        masked(MotionKernels::allocate_masked_levels(ctx, live, "model " + std::to_string(id_) + " masked live")),
        first_frame(frame),
        last_frame(frame) {
    residuals = gpu::Buffer::create(ctx, size_t(intrinsics.width) * intrinsics.height * 16,
                                    "model " + std::to_string(id_) + " motion residuals");
    stream.set_profile_group(id_ == 0 ? "background" : "objects");
  }
  static TrackerParams tracker_params(const CoFusionParams& p, int id) {
    TrackerParams t = p.slam.tracker;
    if (id != 0) {
      t.min_inlier_ratio = p.lifecycle.object_min_inlier_ratio;
      t.outline_photometric = p.lifecycle.object_outline_photometric;
      // While the outline term is off (as CoFusion::choose_object_terms decides each frame).
      t.photometric_skip_rim = p.lifecycle.object_photometric_skip_rim && !t.outline_photometric;
      t.photometric_weight = p.lifecycle.object_photometric_weight;
      t.max_intensity_diff = p.lifecycle.object_max_intensity_diff;
      t.photometric_huber_k = p.lifecycle.object_photometric_huber_k;
      t.outline_huber_scale = p.lifecycle.object_outline_huber_scale;
      t.icp_noise_reference_depth_m = p.lifecycle.object_icp_noise_reference_depth_m;
      t.iterations_per_level = p.lifecycle.object_iterations_per_level;
    } else {
      if (p.camera_check.enabled && p.camera_check.photometric_weight > 0)
        t.photometric_weight = p.camera_check.photometric_weight;
      t.photometric_tile_weights = p.camera_check.photometric_tile_cap > 0;
    }
    return t;
  }

  int id;
  int slot;  // label slot while active, else kInactiveSlot or kRemovedSlot
  ModelState state = ModelState::kActive;
  gpu::Stream stream;
  SurfelModel surfels;
  ModelPrediction prediction;
  Tracker tracker;
  std::vector<kernels::FramePyramid::Level> masked;  // live levels with the vertices this model owned
  gpu::BufferPtr residuals;                   // vec4 per pixel (motion_kernels.h)
  // The read-back residuals of residual_rect's rows, from its first row on (`residuals`' own
  // mapping, or residuals_readback's where it has none); valid until the next compute_residuals.
  const float* residual_rows = nullptr;
  gpu::BufferPtr residuals_readback;          // host-visible copy of `residuals` where it is not mapped
  // Objects work only where they are: tracking, masking and fusion in the bounding rectangle of
  // their labelled pixels (previous segmentation for tracking, this one for fusion), residuals in
  // that of the previous segmentation grown by MotionCostParams::object_margin_px. The
  // background works on the whole image.
  PixelRect track_rect, residual_rect;

  // This frame.
  bool tracked = false;
  TrackingResult tracking;
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();       // T_reference_live of this frame
  Eigen::Isometry3d last_motion = Eigen::Isometry3d::Identity();  // previous frame's, the guess
  bool guess_from_centroid_step = false;  // last_motion is its region's centroid step (spawn, re-activation)
  bool motion_refused = false;  // the background's tracked motion was refused: nothing is fused
  // The motion that the next frame's guess continues where it is not `motion`: a correction of the
  // camera's pose (CameraCheckParams::keyframe_pull_gain) is not a velocity.
  std::optional<Eigen::Isometry3d> velocity_motion;
  // The live frame in the view its prediction was made from: the residuals' transform (`motion`,
  // except after a relocalisation, which predicts from the recovered pose).
  Eigen::Isometry3d T_prediction_live = Eigen::Isometry3d::Identity();
  bool settled = false;  // its residuals are this frame's (else it has no costs this frame)
  int pixels = 0;
  // Surfels culled this frame for the capacity limit (fusion, merges); the first cull of a model
  // is reported as a warning event, later ones are not.
  unsigned culled = 0;
  bool limit_reported = false;
  int rigidity_failures = 0;  // frames of its rigidity trial that counted against it

  // Its pose when it last covered a spawn-sized region and tracked (an object leaving the view is
  // tracked from fewer and fewer pixels at the border: that pose is the better guess when it
  // comes back).
  std::optional<Eigen::Isometry3d> T_world_model_last_seen;

  int first_frame;
  int last_frame;
  int unseen_frames = 0;
  int coasted_frames = 0;  // consecutive failed trackings it kept its last motion for (coast_frames)
  bool on_probation = true;  // objects: not yet shown to move relative to the background
  // Spawned by LifecycleParams::spawn_persist_*: the world centroid of its region where its
  // candidate track began; its probation also counts the travel from there.
  std::optional<Eigen::Vector3d> probation_start_world;
  // Spawned by motion: its spawn frame (observed_motion.h), which tests while it is on probation
  // whether its motion shows in its pixels; empty for other models.
  SpawnEvidence probation_evidence;
  // A model spawned from an instance mask that has not been seen to move (SemanticParams::
  // resting_max_unexplained_fraction): it keeps its world pose without being tracked, and the
  // background keeps its surfels and tracks the camera with its pixels.
  bool resting = false;
  std::optional<internal::SurfelExtent> extent;  // of its surfels, from when it last went inactive
  PoseHistory trajectory;  // (frame, T_world_model) while active
  PoseHistory seen_trajectory;  // of those, the frames it was tracked in
  ClassVotes class_votes;  // its recognitions by instance masks (semantic_masks.h)
};

}  // namespace cofusion::slam
