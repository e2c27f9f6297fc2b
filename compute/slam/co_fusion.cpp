#include "slam/co_fusion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <cstdio>
#include <numeric>
#include <span>

#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include "common/se3.h"
#include "common/window_count.h"

namespace cofusion::slam {
namespace {
using Clock = std::chrono::steady_clock;
double ms_between(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

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

double rotation_deg(const Eigen::Isometry3d& T) { return rotation_angle_rad(T) * 180.0 / M_PI; }

// Bounding rectangle of each slot's pixels in a label map (empty for slots without pixels).
std::vector<PixelRect> slot_rects(const std::vector<uint8_t>& slots, int width, int height) {
  std::vector<PixelRect> rects(256, PixelRect{width, height, 0, 0});
  for (int y = 0; y < height; ++y) {
    const uint8_t* row = slots.data() + size_t(y) * size_t(width);
    for (int x = 0; x < width; ++x) {
      PixelRect& r = rects[row[x]];
      r.x0 = std::min(r.x0, x), r.x1 = std::max(r.x1, x + 1);
      r.y0 = std::min(r.y0, y), r.y1 = std::max(r.y1, y + 1);
    }
  }
  for (PixelRect& r : rects)
    if (r.empty()) r = PixelRect{};
  return rects;
}

// Surfels of one model expressed in another frame: T_to_from maps positions, its rotation normals.
void transform_surfels(std::vector<Surfel>& surfels, const Eigen::Isometry3d& T_to_from) {
  const Eigen::Matrix3f R = T_to_from.rotation().cast<float>();
  const Eigen::Vector3f t = T_to_from.translation().cast<float>();
  for (Surfel& s : surfels) {
    const Eigen::Vector3f p = R * Eigen::Vector3f(s.px, s.py, s.pz) + t;
    const Eigen::Vector3f n = R * Eigen::Vector3f(s.nx, s.ny, s.nz);
    s.px = p.x(), s.py = p.y(), s.pz = p.z();
    s.nx = n.x(), s.ny = n.y(), s.nz = n.z();
  }
}
}  // namespace

const char* to_string(ModelState state) { return state == ModelState::kActive ? "active" : "inactive"; }
const char* to_string(CameraState state) {
  switch (state) {
    case CameraState::kTracking: return "tracking";
    case CameraState::kLost: return "lost";
    case CameraState::kRecovered: return "recovered";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------------
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
      t.iterations_per_level = p.lifecycle.object_iterations_per_level;
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
  std::vector<float> residuals_host;          // its read-back (valid in residual_rect's rows)
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
  bool on_probation = true;  // objects: not yet shown to move relative to the background
  PoseHistory trajectory;  // (frame, T_world_model) while active
  PoseHistory seen_trajectory;  // of those, the frames it was tracked in
  ClassVotes class_votes;  // its recognitions by instance masks (semantic_masks.h)
};

// ---------------------------------------------------------------------------------------------
CoFusion::CoFusion(gpu::Context& ctx, const Intrinsics& intrinsics, const CoFusionParams& params)
    : ctx_(ctx),
      intrinsics_(intrinsics),
      params_(params),
      main_stream_(ctx, 0, "co-fusion main"),
      preprocessor_(ctx),
      surfels_(ctx, preprocessor_),
      motion_(ctx),
      segmenter_(params.segmentation),
      live_(kernels::FramePyramid::allocate(ctx, intrinsics, params.slam.preprocess.pyramid_levels, "live")),
      keyframes_(params.relocalisation.keyframes) {
  for (const auto& [counts, name] : {std::pair{&params.slam.tracker.iterations_per_level, "tracker"},
                                      std::pair{&params.lifecycle.object_iterations_per_level,
                                                "lifecycle.object_iterations_per_level"}})
    if (int(counts->size()) < params.slam.preprocess.pyramid_levels)
      throw Error(std::string(name) + " needs iterations for each of the " +
                  std::to_string(params.slam.preprocess.pyramid_levels) + " pyramid levels");
  if (params.lifecycle.max_active_models < 1 || params.lifecycle.max_active_models > kMoverSlot)
    throw Error("lifecycle.max_active_models must be in [1, " + std::to_string(kMoverSlot) + "]");
  const RelocalisationParams& reloc = params.relocalisation;
  if (reloc.candidate_keyframes < 0 || reloc.recent_frames < 1 || !(reloc.min_inlier_ratio_rel >= 0) ||
      !(reloc.max_rms_rel > 0) || reloc.settle_frames < 0 || reloc.tracking_passes < 1)
    throw Error("relocalisation: candidate_keyframes and settle_frames must be >= 0, recent_frames >= 1, "
                "min_inlier_ratio_rel >= 0, max_rms_rel > 0, tracking_passes >= 1");
  const LifecycleParams& life = params.lifecycle;
  if (life.rigidity_trial_frames < 0 || life.rigidity_max_failures < 1 ||
      !(life.rigid_min_explained_fraction >= 0 && life.rigid_min_explained_fraction <= 1) ||
      !(life.mover_min_overlap > 0 && life.mover_min_overlap <= 1))
    throw Error("lifecycle: rigidity_trial_frames must be >= 0, rigidity_max_failures >= 1, "
                "rigid_min_explained_fraction in [0, 1], mover_min_overlap in (0, 1]");
  const SemanticParams& sem = params.semantic;
  if (sem.confirm_frames < 1 || !(sem.min_instance_area_fraction >= 0 && sem.min_instance_area_fraction < 1) ||
      !(sem.join_min_iou > 0 && sem.join_min_iou <= 1))
    throw Error("semantic: confirm_frames must be >= 1, min_instance_area_fraction in [0, 1), join_min_iou in (0, 1]");
  main_stream_.set_profile_group("frame");
  preprocess_ = params.slam.effective_preprocess();
  // Object trackers differ from the background's (the outline term reads the live gradients).
  preprocess_.live_gradients = preprocess_.live_gradients || Model::tracker_params(params, 1).needs_live_gradients();
  const size_t n = size_t(intrinsics.width) * intrinsics.height;
  labels_ = gpu::Buffer::create(ctx, n * sizeof(uint32_t), "segmentation labels");
  slots_.assign(n, 0);
  create_model(0, Eigen::Isometry3d::Identity());
}

CoFusion::~CoFusion() {
  for (auto& m : models_) m->stream.wait_idle();
  main_stream_.wait_idle();
}

CoFusion::Model& CoFusion::create_model(int slot, const Eigen::Isometry3d& T_world_model) {
  const int id = models_.empty() ? 0 : next_id_++;
  models_.push_back(std::make_unique<Model>(ctx_, intrinsics_, params_, live_.levels, id, slot, frame_));
  Model& m = *models_.back();
  m.surfels.T_world_model = T_world_model;
  if (id == 0) m.on_probation = false;
  return m;
}

std::vector<CoFusion::Model*> CoFusion::live_models() const {
  std::vector<Model*> active;
  for (const auto& m : models_)
    if (m->state == ModelState::kActive) active.push_back(m.get());
  return active;
}

int CoFusion::free_slot(uint32_t taken) const {
  uint32_t used = taken;
  for (const auto& m : models_)
    if (m->state == ModelState::kActive) used |= 1u << m->slot;
  for (int s = 0; s < kMoverSlot; ++s)
    if (!(used & (1u << s))) return s;
  return -1;
}

void CoFusion::upload_labels(const std::vector<uint8_t>& slots) {
  std::vector<uint32_t> wide(slots.size());
  for (size_t i = 0; i < slots.size(); ++i) wide[i] = slots[i] == kNoSlot ? 0xFFFFFFFFu : slots[i];
  main_stream_.upload(labels_, wide.data(), wide.size() * sizeof(uint32_t));
}

// Predict into the previous view and mask the live vertices to the pixels the model owned in the
// previous segmentation. Runs on the model's own stream (and thread); the GPU starts it once the
// preprocessing has signalled its timeline point.
void CoFusion::predict_model(Model& m, const gpu::TimelinePoint& preprocessed) {
  const Eigen::Isometry3d T_camera_model = T_world_camera_.inverse() * m.surfels.T_world_model;
  PredictionParams prediction;
  prediction.min_confidence = params_.slam.fusion.stable_confidence;
  prediction.recent_window_frames = params_.slam.prediction_recent_window_frames;
  // An object is predicted only around the pixels it works on: its residual rectangle, plus as
  // much again for the pixels its motion carries them to.
  std::optional<PixelRect> rect;
  if (m.id != 0) rect = m.residual_rect.grown(params_.costs.object_margin_px);
  gpu::CommandList c = m.stream.begin();
  surfels_.predict(c, m.surfels, T_camera_model, m.prediction, prediction, frame_, rect);
  const bool unclaimed = m.id == 0 && unclaimed_fraction_ > params_.lifecycle.background_tracks_unclaimed_above;
  const uint32_t keep = (1u << m.slot) | (unclaimed ? 1u << kUnclaimedSlot : 0u);
  if (params_.motion_segmentation) motion_.mask_levels(c, live_.levels, m.masked, labels_, keep, m.track_rect);
  // Tracking's submissions are not otherwise ordered after this one: the host waits.
  m.stream.wait(m.stream.submit(std::move(c), std::span(&preprocessed, 1)));
}

// Tracks the model with its own live pixels.
void CoFusion::track_model(Model& m) {
  const Eigen::Isometry3d guess = params_.slam.constant_velocity_guess ? m.last_motion : Eigen::Isometry3d::Identity();
  // Background-only runs track with every live pixel: there is nothing to mask.
  m.tracking = m.tracker.track(m.stream, params_.motion_segmentation ? m.masked : live_.levels, m.prediction.levels, guess,
                               m.track_rect);
  m.tracked = true;
  m.motion = m.tracking.failed ? guess : m.tracking.T_reference_live;
}

// While the camera is lost nothing moves: every model keeps its world pose (its motion is the
// camera's, which is none, or the relocalisation's), counts as failed (so nothing is fused) and has
// no residuals.
void CoFusion::hold_still(const std::vector<Model*>& active, const std::string& why) {
  Model& bg = *active.front();
  if (bg.tracking.failed) bg.motion = Eigen::Isometry3d::Identity();
  for (Model* m : active) {
    m->last_motion = Eigen::Isometry3d::Identity();
    if (m->id == 0) continue;
    m->motion = bg.motion;
    m->tracked = true;
    m->tracking = {};
    m->tracking.failed = true;
    m->tracking.failure_reason = why;
  }
}

// Relocalisation of a lost camera (RelocalisationParams): the background tracked with every live
// pixel from the last tracked pose and from the most similar keyframes' poses. On success the
// background's motion takes the camera to the recovered pose and its residuals are computed there
// (from a prediction at that pose), so this frame is segmented and fused; on failure the frame is
// lost like the one before.
bool CoFusion::relocalise(Model& bg, const FrameEncoding& encoding, const FrameFeatures& features) {
  const RelocalisationParams& p = params_.relocalisation;
  std::vector<Eigen::Isometry3d> starts{T_world_camera_};  // T_world_camera
  for (const Eigen::Isometry3d& T : keyframes_.pnp_poses(encoding, features, intrinsics_))
    starts.push_back(T);
  if (closest_attempt_) starts.push_back(closest_attempt_->second);
  for (const Eigen::Isometry3d& T : keyframes_.nearest(encoding, p.candidate_keyframes)) starts.push_back(T);
  PredictionParams prediction;
  prediction.min_confidence = params_.slam.fusion.stable_confidence;
  prediction.recent_window_frames = params_.slam.prediction_recent_window_frames;
  const auto predict_at = [&](const Eigen::Isometry3d& T_world_view) {
    const Eigen::Isometry3d T_view_model = T_world_view.inverse() * bg.surfels.T_world_model;
    bg.stream.run([&](gpu::CommandList& c) { surfels_.predict(c, bg.surfels, T_view_model, bg.prediction, prediction, frame_); });
  };
  // What the camera's tracking achieved before the loss (medians of the recent frames).
  const auto median = [&](auto field) {
    std::vector<double> v;
    for (const auto& r : recent_tracking_) v.push_back(field(r));
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double min_ratio = p.min_inlier_ratio_rel * median([](const auto& r) { return r.first; });
  const double max_rms = recent_tracking_.empty() ? std::numeric_limits<double>::infinity()
                                                  : p.max_rms_rel * median([](const auto& r) { return r.second; });
  std::optional<std::pair<TrackingResult, Eigen::Isometry3d>> best;  // with T_world_live
  std::optional<std::pair<double, Eigen::Isometry3d>> closest_failure;  // (RMS m, T_world_live)
  TrackingResult failure;
  failure.failed = true;
  failure.failure_reason = "lost; relocalisation found no alignment";
  for (const Eigen::Isometry3d& T_world_start : starts) {
    predict_at(T_world_start);
    TrackingResult r = bg.tracker.track(bg.stream, live_.levels, bg.prediction.levels, Eigen::Isometry3d::Identity());
    // Again from where it got to: tracking's statistics are those of its last iteration, which from
    // a distant start is not converged yet (the finest level runs few iterations).
    for (int pass = 1; pass < p.tracking_passes && !r.failed; ++pass)
      r = bg.tracker.track(bg.stream, live_.levels, bg.prediction.levels, r.T_reference_live);
    if (!r.failed && (r.inlier_ratio < min_ratio || r.icp_rms_m > max_rms)) {
      char why[160];
      std::snprintf(why, sizeof why, "lost; a relocalisation reached inlier ratio %.3f (needs %.3f), RMS %.4f m (at most %.4f)",
                    r.inlier_ratio, min_ratio, r.icp_rms_m, max_rms);
      r.failed = true;
      r.failure_reason = why;
    }
    if (r.failed) {
      // The camera keeps moving while it is lost: the closest miss is the next frame's best start.
      if (r.icp_inliers > 0 && (!closest_failure || r.icp_rms_m < closest_failure->first))
        closest_failure.emplace(r.icp_rms_m, T_world_start * r.T_reference_live);
      failure = r;
      continue;
    }
    if (!best || r.inlier_ratio > best->first.inlier_ratio) best.emplace(r, T_world_start * r.T_reference_live);
  }
  bg.tracked = true;
  closest_attempt_ = best ? std::nullopt : closest_failure;
  if (!best) {
    bg.tracking = failure;
    hold_still(live_models(), failure.failure_reason);
    return false;
  }
  const Eigen::Isometry3d T_world_live = orthonormalised(best->second);
  bg.tracking = best->first;
  bg.motion = T_world_camera_.inverse() * T_world_live;
  hold_still(live_models(), "the camera was relocalised this frame");
  lost_ = false;
  last_recovery_frame_ = frame_;
  if (params_.motion_segmentation) {
    predict_at(T_world_live);
    bg.T_prediction_live = Eigen::Isometry3d::Identity();
    compute_residuals(bg);
  }
  return true;
}

// Once every model is tracked: an object whose pixels staying where it is in the world
// (`camera_motion`, the background's) explains as well as its tracked motion stays (RestParams).
// Then the per-pixel alignment cost of the model's motion over its residual rectangle (the
// segmentation's input).
void CoFusion::settle_model(Model& m, const Eigen::Isometry3d& camera_motion) {
  const RestParams& rest = params_.rest;
  if (m.id != 0 && rest.prefer_rest && !m.tracking.failed && params_.motion_segmentation) {
    const TrackerParams& tp = m.tracker.params();
    const double lambda = tp.use_photometric ? tp.photometric_weight : 0.0;
    // The tracked motion's fit is tracking's last iteration's (at the pose before its final,
    // converged step), so only rest needs a reduction of its own.
    const TrackingResult& t = m.tracking;
    const auto mean_cost = [&](double icp_r2, double icp_n, double rgb_r2, double rgb_n) {
      const double n = icp_n + (lambda > 0 ? rgb_n : 0.0);
      return n > 0 ? (icp_r2 + lambda * rgb_r2) / n : 0.0;
    };
    const double moved_n = t.icp_inliers;
    const double moved_cost = mean_cost(t.icp_rms_m * t.icp_rms_m * moved_n, moved_n, t.rgb_rms * t.rgb_rms * t.rgb_residuals,
                                        t.rgb_residuals);
    const HuberDeltas huber{tp.icp_huber_k * t.icp_rms_m, tp.photometric_huber_k * t.rgb_rms};  // as tracking's last iteration
    const LinearSystemSums still =
        m.tracker.compute_sums(m.stream, m.masked[0], m.prediction.levels[0], camera_motion, m.track_rect, huber);
    const double still_cost = mean_cost(still.icp[27], still.icp[28], still.rgb[27], still.rgb[28]);
    if (moved_n > 0 && still.icp[28] >= rest.min_correspondence_fraction * moved_n &&
        still_cost <= (1.0 + rest.max_cost_increase) * moved_cost)
      m.motion = camera_motion;
  }
  m.last_motion = m.tracking.failed ? Eigen::Isometry3d::Identity() : m.motion;
  m.T_prediction_live = m.motion;
  if (params_.motion_segmentation) compute_residuals(m);
}

// The per-pixel residuals of the live frame against the model's prediction (the live frame taken
// to the prediction's view by T_prediction_live), over its residual rectangle, read back.
void CoFusion::compute_residuals(Model& m) {
  m.stream.run([&](gpu::CommandList& cmd) {
    motion_.residuals(cmd, live_.levels[0], m.prediction.levels[0], m.T_prediction_live, m.residuals, m.residual_rect);
  });
  m.residuals_host.resize(slots_.size() * 4);
  const size_t row_floats = size_t(intrinsics_.width) * 4, offset = size_t(m.residual_rect.y0) * row_floats;
  m.stream.download(m.residuals, m.residuals_host.data() + offset,
                    size_t(m.residual_rect.height()) * row_floats * sizeof(float), offset * sizeof(float));
  m.settled = true;
}

// The segmentation's input for model m: per-pixel alignment cost in metres, NaN = no geometry.
void CoFusion::model_costs(const Model& m, const float* depth_m, std::vector<float>& costs) const {
  const float* r = m.residuals_host.data();
  const size_t n = slots_.size();
  const PixelRect& rect = m.residual_rect;
  const size_t width = size_t(intrinsics_.width);
  // Outside its residual rectangle the model has no geometry; only the rectangle is read.
  costs.assign(n, kNaN);
  if (!m.settled) return;  // not tracked this frame (the camera was relocalised): no evidence
  const MotionCostParams& p = params_.costs;
  const bool background = m.id == 0;
  const auto sigma = [](float z) { return 0.0012f + 0.0019f * (z - 0.4f) * (z - 0.4f); };
  const float z_ref = p.noise_reference_depth_m;
  const float sigma_ref = sigma(z_ref);
  // Photometric residuals in units of this frame's photometric noise (the background's RMS
  // residual after tracking): motion blur and exposure changes raise every pixel's residual. An
  // object's own RMS counts where it is larger: a turning object's faces change their shading
  // (bright squares of a checker more than dark ones), which no motion explains.
  const double rgb_rms = std::max(models_.front()->tracking.rgb_rms, background || m.tracking.failed ? 0.0 : m.tracking.rgb_rms);
  const float photometric_m = rgb_rms > p.photometric_reference_rms
                                  ? float(p.photometric_m * p.photometric_reference_rms / rgb_rms)
                                  : p.photometric_m;
  // Objects: which pixels of the rectangle lie within unseen_surface_reach_px of one where the
  // object has geometry.
  const float* bg_r = models_.front()->residuals_host.data();
  const std::optional<WindowCount> with_geometry =
      background ? std::nullopt
                 : std::optional<WindowCount>(std::in_place, rect.width(), rect.height(), [&](int x, int y) {
                     return r[4 * (size_t(y + rect.y0) * width + size_t(x + rect.x0)) + 3] == MOTION_STATUS_ASSOCIATED;
                   });
  tbb::parallel_for(tbb::blocked_range<int>(rect.y0, rect.y1, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (size_t i = size_t(y) * width + size_t(rect.x0); i < size_t(y) * width + size_t(rect.x1); ++i) {
        const float* v = r + 4 * i;  // (point-to-plane m, live z - predicted z m, |dI|, status)
        if (!background && v[3] == MOTION_STATUS_NO_MODEL) {
          const float* b = bg_r + 4 * i;
          if (b[3] == MOTION_STATUS_ASSOCIATED && b[1] < -p.occluding_margin_m &&
              with_geometry->around(int(i % width) - rect.x0, y - rect.y0, p.unseen_surface_reach_px) > 0)
            costs[i] = p.unseen_surface_cost_m;
          continue;
        }
        if (v[3] != 1.0f) continue;  // no live vertex, or no model geometry there: NaN
        if (background && v[1] > p.revealed_margin_m) {
          costs[i] = p.revealed_cost_m;
        } else {
          const float z = depth_m[i];
          const float scale = z_ref > 0.0f && z > z_ref ? sigma_ref / sigma(z) : 1.0f;
          costs[i] = std::min(v[0] * scale + photometric_m * v[2], p.max_cost_m);
        }
      }
  });
}

void CoFusion::fuse_model(Model& m, const std::vector<int>& duplicate_slots, const PixelRect& fuse_rect) {
  const Eigen::Isometry3d T_camera_model = T_world_camera_.inverse() * m.surfels.T_world_model;
  for (int duplicate_slot : duplicate_slots)
    surfels_.remove_region(m.stream, m.surfels, live_, T_camera_model, labels_, static_cast<unsigned>(duplicate_slot),
                           params_.lifecycle.duplicate_margin_rel);
  if (m.tracking.failed) return;  // a guessed pose would corrupt the model
  const FusionStats stats =
      surfels_.fuse(m.stream, m.surfels, live_, T_camera_model, frame_, params_.slam.fusion,
                    params_.motion_segmentation ? labels_ : nullptr, static_cast<unsigned>(m.slot),
                    m.id == 0 ? std::nullopt : std::optional(fuse_rect));
  m.culled += stats.culled;
}

// The first time a model reaches its capacity limit: a warning event (the run goes on).
void CoFusion::report_cull(Model& m, CoFusionFrame& out) {
  if (m.culled == 0) return;
  if (!m.limit_reported) {
    const unsigned pixels = unsigned(intrinsics_.width) * unsigned(intrinsics_.height);
    out.events.push_back("frame " + std::to_string(frame_) + ": warning: model " + std::to_string(m.id) +
                         " reached its limit of " + std::to_string(m.surfels.limit(pixels, params_.slam.fusion.max_surfels)) +
                         " surfels; culled its " + std::to_string(m.culled) +
                         " least confident surfels and goes on (later culls are not reported)");
    m.limit_reported = true;
  }
  m.culled = 0;
}

// ---------------------------------------------------------------------------------------------
CoFusionFrame CoFusion::process(const float* depth_m, const uint8_t* rgb, const SemanticFrame* semantic) {
  CoFusionFrame out;
  out.frame = frame_;
  const int width = intrinsics_.width, height = intrinsics_.height;
  const size_t n = size_t(width) * height;
  // Pixels of excluded classes (SemanticParams::exclude): mover pixels from the start, so that no
  // model tracks with them this frame, and again after the segmentation.
  std::vector<uint8_t> excluded;
  semantic_ = semantic;
  if (semantic) {
    check_semantic_frame(*semantic, n);
    if (excluded_pixels(*semantic, params_.semantic, excluded) > 0 && !params_.motion_segmentation)
      throw Error("excluding classes by their masks needs motion segmentation (not implemented for background-only runs)");
    if (mark_excluded(excluded, kMoverSlot, slots_)) upload_labels(slots_);
  }
  auto lap = Clock::now();
  const auto stage = [&](const char* name) {
    const auto now = Clock::now();
    out.stage_ms.emplace_back(name, ms_between(lap, now));
    lap = now;
  };

  std::vector<Model*> active;
  for (auto& m : models_)
    if (m->state == ModelState::kActive) active.push_back(m.get());
  for (Model* m : active) m->tracked = false, m->settled = false, m->tracking = {};
  {
    // Where each model works this frame (see Model::track_rect).
    const std::vector<PixelRect> rects = slot_rects(slots_, width, height);
    const PixelRect full = PixelRect::full(width, height);
    for (Model* m : active) {
      m->track_rect = m->id == 0 ? full : rects[size_t(m->slot)];
      m->residual_rect = m->id == 0 ? full : m->track_rect.grown(params_.costs.object_margin_px).clamped(width, height);
    }
  }

  live_.upload(main_stream_, depth_m, rgb);
  stage("upload");

  // CPU job system: superpixels of this frame while the GPU preprocesses, predicts and tracks.
  const Clock::time_point gpu_start = Clock::now();
  const bool segmenting = params_.motion_segmentation && frame_ > 0;
  tbb::task_group cpu_jobs;
  std::optional<segmentation::Superpixels> superpixels;
  Clock::time_point sp_start, sp_end;
  if (segmenting)
    cpu_jobs.run([&] {
      sp_start = Clock::now();
      superpixels = segmenter_.superpixels(rgb, depth_m, width, height);
      sp_end = Clock::now();
    });
  // The frame's keyframe encoding: for relocalisation now when lost, else for the database later.
  FrameEncoding encoding;
  const auto encode = [&] { encoding = keyframes_.encode(rgb, depth_m, width, height); };
  if (lost_)
    encode();
  else
    cpu_jobs.run(encode);

  gpu::CommandList pre = main_stream_.begin();
  preprocessor_.record_frame(pre, live_, kernels::FramePyramid::kUploadMetresPerUnit, preprocess_);
  const gpu::TimelinePoint preprocessed = main_stream_.submit(std::move(pre));
  main_stream_.wait(preprocessed);
  stage("preprocess");

  // One task per model, each on its own stream: models run concurrently where the device has
  // several queues, and their host-side work (recording, the 6x6 solves) overlaps everywhere.
  const auto for_each_model = [](const std::vector<Model*>& models, const auto& work) {
    tbb::task_group jobs;
    for (Model* m : models) jobs.run([m, &work] { work(*m); });
    jobs.wait();
  };
  Model& bg = *active.front();
  CameraState camera = CameraState::kTracking;
  if (frame_ > 0 && !lost_) {
    for_each_model(active, [&](Model& m) { predict_model(m, preprocessed); });
    stage("predict");
    for_each_model(active, [&](Model& m) { track_model(m); });
    if (bg.tracking.failed) {
      camera = CameraState::kLost;
      lost_ = true;
      hold_still(active, bg.tracking.failure_reason);
    } else {
      const Eigen::Isometry3d camera_motion = bg.motion;
      for_each_model(active, [&](Model& m) { settle_model(m, camera_motion); });
    }
    stage("track");
  } else if (frame_ > 0) {
    camera = relocalise(bg, encoding, keyframes_.features(rgb, depth_m, intrinsics_)) ? CameraState::kRecovered
                                                                                      : CameraState::kLost;
    if (camera == CameraState::kRecovered) out.events.push_back("frame " + std::to_string(frame_) + ": camera relocalised");
    stage("relocalise");
  }
  out.camera_state = camera;
  const Clock::time_point gpu_end = Clock::now();

  // Poses: the background's motion is the camera's; every other model's follows from its own.
  const Eigen::Isometry3d T_world_camera_prev = T_world_camera_;
  if (frame_ > 0) {
    T_world_camera_ = orthonormalised(T_world_camera_prev * bg.motion);
    out.camera_tracking = bg.tracking;
    for (Model* m : active)
      if (m->id != 0)
        m->surfels.T_world_model = orthonormalised(T_world_camera_ * m->motion.inverse() * T_world_camera_prev.inverse() *
                                                   m->surfels.T_world_model);
  }
  out.T_world_camera = T_world_camera_;

  std::vector<int> spawned_slots;
  cpu_jobs.wait();
  if (segmenting && camera == CameraState::kLost) {
    // Nothing is known of this frame's motion: no segmentation, no fusion (every model's tracking
    // counts as failed), and the previous labels stay for the next frame.
  } else if (segmenting) {
    out.superpixels_ms = ms_between(sp_start, sp_end);
    out.superpixels_overlap_ms = std::max(0.0, ms_between(std::max(sp_start, gpu_start), std::min(sp_end, gpu_end)));
    const auto seg_start = Clock::now();
    std::vector<std::vector<float>> costs(active.size());
    for (size_t k = 0; k < active.size(); ++k) model_costs(*active[k], depth_m, costs[k]);
    std::vector<std::span<const float>> views(costs.begin(), costs.end());
    segmentation::SegmentationResult seg = segmenter_.segment(*superpixels, rgb, depth_m, views);
    // Excluded pixels are no model's and no outlier region's (they spawn nothing).
    mark_excluded(excluded, segmentation::kNoLabel, seg.labels);
    slots_ = apply_lifecycle(seg, costs, depth_m, active, out, spawned_slots);
    if (mark_excluded(excluded, kMoverSlot, slots_)) upload_labels(slots_);
    out.segment_ms = ms_between(seg_start, Clock::now());
  } else {
    // Everything with depth belongs to the background. The GPU needs the labels only to mask
    // the next frame's tracking, which a background-only run does not do.
    for (size_t i = 0; i < n; ++i) slots_[i] = depth_m[i] > 0.0f ? 0 : kNoSlot;
    mark_excluded(excluded, kMoverSlot, slots_);
    if (params_.motion_segmentation) upload_labels(slots_);
    active.front()->pixels = static_cast<int>(std::count(slots_.begin(), slots_.end(), uint8_t{0}));
  }
  stage("segment");

  // Fusion, one task per active model (a new one included).
  std::vector<Model*> fusing;
  for (auto& m : models_)
    if (m->state == ModelState::kActive) fusing.push_back(m.get());
  const std::vector<PixelRect> fuse_rects = slot_rects(slots_, width, height);
  // A new model's geometry may already be in other models: the background (an object that
  // started moving after it was fused) or an object it moved with until now (an arm that carried
  // the cube and lets go). Each older model drops its surfels on the new region's pixels.
  for_each_model(fusing, [&](Model& m) {
    const bool is_new = std::find(spawned_slots.begin(), spawned_slots.end(), m.slot) != spawned_slots.end();
    fuse_model(m, is_new ? std::vector<int>{} : spawned_slots, fuse_rects[size_t(m.slot)]);
  });
  stage("fuse");

  // Bookkeeping and the report.
  std::vector<uint16_t> slot_to_id(kSlots, 0xFFFF);
  for (auto& m : models_) {
    report_cull(*m, out);
    if (m->state != ModelState::kActive) continue;
    slot_to_id[m->slot] = static_cast<uint16_t>(m->id);
    m->trajectory.emplace_back(frame_, m->surfels.T_world_model);
    // A failed tracking leaves a guessed pose (an object that left the view): not reported.
    if (!(m->tracked && m->tracking.failed)) m->seen_trajectory.emplace_back(frame_, m->surfels.T_world_model);
    ModelStatus s;
    s.id = m->id;
    s.state = m->state;
    s.T_world_model = m->surfels.T_world_model;
    s.surfels = m->surfels.count();
    s.first_frame = m->first_frame;
    s.last_frame = m->last_frame;
    s.pixels = m->pixels;
    s.tracked = m->tracked;
    s.tracking = m->tracking;
    out.active.push_back(s);
  }
  out.labels.assign(n, 0xFFFF);
  if (camera != CameraState::kLost)
    for (size_t i = 0; i < n; ++i) out.labels[i] = slots_[i] < kMoverSlot ? slot_to_id[slots_[i]] : uint16_t{0xFFFF};
  if (camera == CameraState::kTracking)
    keyframes_.add_if_novel(encoding, [&] { return keyframes_.features(rgb, depth_m, intrinsics_); }, T_world_camera_);
  if (camera == CameraState::kTracking && frame_ > 0) {
    recent_tracking_.emplace_back(bg.tracking.inlier_ratio, bg.tracking.icp_rms_m);
    if (int(recent_tracking_.size()) > params_.relocalisation.recent_frames) recent_tracking_.erase(recent_tracking_.begin());
  }
  ++frame_;
  semantic_ = nullptr;  // the caller's, valid during process() only
  return out;
}

// ---------------------------------------------------------------------------------------------
bool relative_pose_held(const PoseHistory& a, const PoseHistory& b, const Eigen::Isometry3d& T_a_b,
                        double max_translation_m, double max_rotation_deg) {
  auto ia = a.begin();
  for (const auto& [frame, T_world_b] : b) {
    while (ia != a.end() && ia->first < frame) ++ia;
    if (ia == a.end()) break;
    if (ia->first != frame) continue;
    const Eigen::Isometry3d change = (ia->second.inverse() * T_world_b).inverse() * T_a_b;
    if (change.translation().norm() > max_translation_m || rotation_deg(change) > max_rotation_deg) return false;
  }
  return true;
}

// Turns the segmentation (labels = index into `order`, order.size() = outlier) into model slots
// and applies the lifecycle rules. Uploads the final label map.
std::vector<uint8_t> CoFusion::apply_lifecycle(const segmentation::SegmentationResult& seg,
                                               const std::vector<std::vector<float>>& costs, const float* depth_m,
                                               std::vector<Model*>& order, CoFusionFrame& out,
                                               std::vector<int>& spawned_slots) {
  const LifecycleParams& p = params_.lifecycle;
  const int width = intrinsics_.width, height = intrinsics_.height;
  const size_t n = size_t(width) * height;
  const uint8_t outlier = static_cast<uint8_t>(order.size());
  std::vector<uint8_t> slots(n, kNoSlot);
  const float max_cost = params_.costs.max_explained_cost_m;
  // Per model: pixels the segmentation gave it, and of those the ones its motion explains.
  std::vector<int> labelled(order.size(), 0), explained(order.size(), 0);
  for (size_t i = 0; i < n; ++i) {
    const uint8_t l = seg.labels[i];
    if (l < outlier) ++labelled[l];
    if (l < outlier && !(costs[l][i] > max_cost)) {
      slots[i] = static_cast<uint8_t>(order[l]->slot);
      ++explained[l];
    } else if (l == outlier || (l == segmentation::kNoLabel && depth_m[i] > 0.0f)) {
      slots[i] = kUnclaimedSlot;
    }
  }
  Model& bg = *order.front();
  drop_nonrigid(order, seg.labels, labelled, explained, slots, out);

  // Merges. A young model that has not moved relative to the background is no object; two models
  // moving as one body become one. Their pixels go to the model they merge into.
  const auto relabel = [&](int from, int to) {
    for (auto& s : slots)
      if (s == from) s = static_cast<uint8_t>(to);
  };
  for (Model* m : order) {
    if (m->id == 0 || m->state != ModelState::kActive || !m->on_probation) continue;
    const Eigen::Isometry3d moved = m->trajectory.front().second.inverse() * m->surfels.T_world_model;
    if (moved.translation().norm() >= p.static_translation_m || rotation_deg(moved) >= p.static_rotation_deg) {
      m->on_probation = false;
    } else if (frame_ - m->first_frame >= p.probation_frames) {
      relabel(m->slot, bg.slot);
      merge_into(bg, *m, out, "did not move relative to the background");
    }
  }
  for (Model* a : order) {
    for (Model* b : order) {
      if (a->id == 0 || b->id <= a->id || a->state != ModelState::kActive || b->state != ModelState::kActive) continue;
      if (a->on_probation || b->on_probation) continue;
      const int window = p.merge_window_frames;
      if (int(a->trajectory.size()) <= window || int(b->trajectory.size()) <= window) continue;
      const auto pose_at = [](const Model& m, size_t back) { return m.trajectory[m.trajectory.size() - 1 - back].second; };
      const Eigen::Isometry3d rel_now = a->surfels.T_world_model.inverse() * b->surfels.T_world_model;
      const Eigen::Isometry3d rel_then = pose_at(*a, window - 1).inverse() * pose_at(*b, window - 1);
      const Eigen::Isometry3d change = rel_then.inverse() * rel_now;
      const Eigen::Isometry3d a_moved = pose_at(*a, window - 1).inverse() * a->surfels.T_world_model;
      const Eigen::Isometry3d b_moved = pose_at(*b, window - 1).inverse() * b->surfels.T_world_model;
      const auto moved = [&](const Eigen::Isometry3d& T) {
        return T.translation().norm() >= p.static_translation_m || rotation_deg(T) >= p.static_rotation_deg;
      };
      if (change.translation().norm() < p.merge_translation_m && rotation_deg(change) < p.merge_rotation_deg &&
          moved(a_moved) && moved(b_moved) &&
          relative_pose_held(a->trajectory, b->trajectory, rel_now, p.merge_history_translation_m,
                             p.merge_history_rotation_deg)) {
        relabel(b->slot, a->slot);
        merge_into(*a, *b, out, "moves with model " + std::to_string(a->id));
      }
    }
  }

  // Every connected outlier region (4-connectivity) between spawn_min_area_fraction and
  // spawn_max_area_fraction of the image is a candidate new model; it spawns one once it was a
  // candidate in the previous frame too (several objects starting to move at once each spawn).
  segmentation::label_components(seg.labels.data(), width, height, std::optional<uint8_t>{}, components_);
  const std::vector<char> mover = mark_movers(outlier, slots);
  std::vector<std::vector<size_t>> regions;  // pixels of each large outlier region, largest first
  {
    std::vector<int> large_components;
    for (int c = 0; c < int(components_.components.size()); ++c) {
      const auto& info = components_.components[size_t(c)];
      if (info.value == outlier && !mover[size_t(c)] && double(info.pixels) > p.spawn_min_area_fraction * double(n) &&
          double(info.pixels) <= p.spawn_max_area_fraction * double(n))
        large_components.push_back(c);
    }
    std::sort(large_components.begin(), large_components.end(), [&](int x, int y) {
      return components_.components[size_t(x)].pixels > components_.components[size_t(y)].pixels;
    });
    std::vector<int> region_of(components_.components.size(), -1);
    for (size_t r = 0; r < large_components.size(); ++r) region_of[size_t(large_components[r])] = int(r);
    regions.resize(large_components.size());
    for (const auto& run : components_.runs)
      if (run.component >= 0 && region_of[size_t(run.component)] >= 0)
        for (int x = run.x0; x < run.x1; ++x)
          regions[size_t(region_of[size_t(run.component)])].push_back(size_t(run.y) * size_t(width) + size_t(x));
  }
  int active_count = 0;
  for (auto& m : models_) active_count += m->state == ModelState::kActive;
  const bool camera_steady = !bg.tracking.failed && bg.motion.translation().norm() <= p.spawn_max_camera_translation_m &&
                             rotation_deg(bg.motion) <= p.spawn_max_camera_rotation_deg &&
                             frame_ - last_recovery_frame_ >= params_.relocalisation.settle_frames;
  // Centroid (camera frame) of a region's live points: a new model's origin, and with the previous
  // frame's candidate it overlaps most the region's motion over the last frame.
  const auto centroid_of = [&](const std::vector<size_t>& pixels) -> std::optional<Eigen::Vector3d> {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    size_t count = 0;
    for (size_t i : pixels) {
      const float d = depth_m[i];
      if (!(d > 0.0f)) continue;
      const double x = double(i % width), y = double(i / width);
      sum += Eigen::Vector3d((x - intrinsics_.cx) / intrinsics_.fx * d, (y - intrinsics_.cy) / intrinsics_.fy * d, d);
      ++count;
    }
    if (count == 0) return std::nullopt;
    return sum / double(count);
  };
  const std::vector<uint8_t> previous_candidates = std::move(spawn_candidate_);
  const std::vector<std::optional<Eigen::Vector3d>> previous_centroids = std::move(spawn_candidate_centroids_);
  spawn_candidate_.assign(n, 0);
  spawn_candidate_centroids_.clear();
  struct Spawn {
    size_t region;
    int slot;
    std::optional<Eigen::Vector3d> centroid, previous_centroid;
  };
  std::vector<Spawn> spawns;
  // Semantic mode: models come from instance masks only.
  if (params_.semantic.mode == SegmentationMode::kSemantic) regions.clear();
  for (size_t r = 0; r < regions.size(); ++r) {
    const std::vector<size_t>& pixels = regions[r];
    const std::optional<Eigen::Vector3d> centroid = centroid_of(pixels);
    // A region must be there in consecutive frames: transient outliers (a blurred frame, a depth
    // glitch) spawn nothing. Which previous candidate it overlaps most gives its last position.
    std::vector<size_t> overlap(previous_centroids.size() + 1, 0);
    if (previous_candidates.size() == n)
      for (size_t i : pixels) ++overlap[previous_candidates[i]];
    size_t confirmed = 0, best_previous = 0;
    for (size_t k = 1; k < overlap.size(); ++k) {
      confirmed += overlap[k];
      if (overlap[k] > overlap[best_previous]) best_previous = k;
    }
    const bool persistent = double(confirmed) >= p.spawn_min_overlap * double(pixels.size());
    if (frame_ >= p.warmup_frames && camera_steady && persistent &&
        active_count + int(spawns.size()) < p.max_active_models) {
      spawns.push_back({r, -1, centroid, best_previous > 0 ? previous_centroids[best_previous - 1] : std::nullopt});
    } else if (spawn_candidate_centroids_.size() < 254) {  // a candidate for the next frame
      spawn_candidate_centroids_.push_back(centroid);
      for (size_t i : pixels) spawn_candidate_[i] = static_cast<uint8_t>(spawn_candidate_centroids_.size());
    }
  }
  // Pixels per slot, kept up to date as the new regions take their (free) slots; an object model
  // whose slot has none lost its object in this segmentation.
  std::vector<int> slot_pixels(kSlots, 0);
  for (uint8_t sl : slots)
    if (sl != kNoSlot) ++slot_pixels[sl];
  const auto lost = [&](const Model& m) { return m.slot >= 0 && slot_pixels[size_t(m.slot)] == 0; };
  uint32_t taken = 0;  // slots given to this frame's new models
  for (Spawn& sp : spawns) {
    sp.slot = free_slot(taken);
    taken |= 1u << sp.slot;
    for (size_t i : regions[sp.region]) {
      if (slots[i] != kNoSlot) --slot_pixels[slots[i]];
      slots[i] = static_cast<uint8_t>(sp.slot);
      ++slot_pixels[size_t(sp.slot)];
    }
  }
  if (semantic_) apply_instances(slots, slot_pixels, taken, depth_m, out, spawned_slots);
  upload_labels(slots);

  for (const Spawn& sp : spawns) {
    const std::vector<size_t>& pixels = regions[sp.region];
    const Eigen::Vector3d centroid = sp.centroid.value_or(Eigen::Vector3d::Zero());
    const double percent = 100.0 * double(pixels.size()) / double(n);
    char share[32];
    std::snprintf(share, sizeof share, "%.1f%%", percent);
    // A new or re-activated model has no velocity yet; the region's centroid moved by `step` over
    // the last frame, which is the first tracking's guess (an object entering fast, 3 cm per
    // frame, moves out of the pixels its model is masked to, and from a zero guess the model stays
    // put).
    Eigen::Isometry3d velocity_guess = Eigen::Isometry3d::Identity();
    if (sp.centroid && sp.previous_centroid) {
      const Eigen::Vector3d step = *sp.centroid - *sp.previous_centroid;
      if (step.norm() <= p.spawn_max_velocity_guess_m)
        velocity_guess = Eigen::Translation3d(-step) * Eigen::Isometry3d::Identity();
    }
    // First an object model that lost every pixel this frame (its tracking slipped off the object,
    // which now shows up as an outlier region), then the inactive ones.
    Model* reactivated = nullptr;
    bool was_active = false;
    if (p.reactivate)
      for (const ModelState state : {ModelState::kActive, ModelState::kInactive}) {
        for (auto& m : models_) {
          // A model merged away this frame is inactive until the list is pruned: not a candidate.
          if (m->state != state || m->id == 0 || m->slot == kRemovedSlot || (state == ModelState::kActive && !lost(*m))) continue;
          if (try_reactivate(*m, sp.slot, centroid)) {
            reactivated = m.get();
            was_active = state == ModelState::kActive;
            break;
          }
        }
        if (reactivated) break;
      }
    if (reactivated) {
      reactivated->last_motion = velocity_guess;
      out.events.push_back("frame " + std::to_string(frame_) + ": " + (was_active ? "re-found model " : "re-activated model ") +
                           std::to_string(reactivated->id) + " (" + share + " of the image)");
    } else {
      Eigen::Isometry3d T_camera_model = Eigen::Isometry3d::Identity();
      T_camera_model.translation() = centroid;
      Model& m = create_model(sp.slot, T_world_camera_ * T_camera_model);
      m.pixels = static_cast<int>(pixels.size());
      m.last_motion = velocity_guess;
      spawned_slots.push_back(sp.slot);
      out.events.push_back("frame " + std::to_string(frame_) + ": spawned model " + std::to_string(m.id) + " (" +
                           share + " of the image)");
    }
  }

  // Pixel counts, absence and retirement.
  unclaimed_fraction_ = double(slot_pixels[kUnclaimedSlot]) / double(n);
  for (auto& m : models_) {
    if (m->state != ModelState::kActive) continue;
    m->pixels = slot_pixels[size_t(m->slot)];
    if (m->id != 0 && m->tracked && !m->tracking.failed && double(m->pixels) >= p.spawn_min_area_fraction * double(n))
      m->T_world_model_last_seen = m->surfels.T_world_model;
    if (m->pixels > 0) {
      m->last_frame = frame_;
      m->unseen_frames = 0;
    } else if (m->id != 0 && ++m->unseen_frames >= p.deactivate_after_frames) {
      retire(*m, out);
    }
  }
  // Deleted models leave the list.
  std::erase_if(models_, [](const std::unique_ptr<Model>& m) { return m->slot == kRemovedSlot; });
  return slots;
}

// Instance masks (SemanticParams): an instance of a modelled class votes for the object model whose
// footprint (its labelled pixels in the previous frame or in this segmentation) it overlaps with
// IoU >= join_min_iou; in semantic/both modes its pixels then join that model. In those modes an
// instance no model covers for confirm_frames consecutive frames spawns a model (no probation: it
// need not move), its surfels removed from the older models as a motion spawn's are.
void CoFusion::apply_instances(std::vector<uint8_t>& slots, std::vector<int>& slot_pixels, uint32_t& taken,
                               const float* depth_m, CoFusionFrame& out, std::vector<int>& spawned_slots) {
  const SemanticParams& sp = params_.semantic;
  const size_t n = slots.size();
  const bool modelling = sp.mode != SegmentationMode::kMotion;
  const std::vector<MaskInstance> instances =
      modelled_instances(*semantic_, sp, depth_m, size_t(sp.min_instance_area_fraction * double(n)));
  std::vector<int> previous_pixels(kSlots, 0);
  if (slots_.size() == n)
    for (uint8_t s : slots_)
      if (s < kSlots) ++previous_pixels[s];
  const uint32_t pending = taken;  // slots of this frame's motion spawns
  std::vector<const MaskInstance*> uncovered;
  for (const MaskInstance& inst : instances) {
    Model* best = nullptr;
    double best_iou = 0;
    for (auto& m : models_) {
      if (m->id == 0 || m->state != ModelState::kActive || m->slot < 0) continue;
      const auto slot = static_cast<uint8_t>(m->slot);
      double v = iou(inst.pixels, slots, slot, size_t(slot_pixels[slot]));
      if (slots_.size() == n) v = std::max(v, iou(inst.pixels, slots_, slot, size_t(previous_pixels[slot])));
      if (v > best_iou) best_iou = v, best = m.get();
    }
    // A region that spawns a model from motion this frame (both mode) covers it too.
    bool spawning = false;
    for (int s = 0; s < kSlots && !spawning; ++s)
      spawning = (pending & (1u << s)) && iou(inst.pixels, slots, uint8_t(s), size_t(slot_pixels[size_t(s)])) >= sp.join_min_iou;
    if (spawning) continue;
    if (best && best_iou >= sp.join_min_iou) {
      best->class_votes.add(inst.class_name);
      if (modelling)
        for (size_t i : inst.pixels) {
          if (slots[i] != kNoSlot) --slot_pixels[slots[i]];
          slots[i] = static_cast<uint8_t>(best->slot);
          ++slot_pixels[size_t(best->slot)];
        }
    } else {
      uncovered.push_back(&inst);
    }
  }
  if (!modelling) return;
  // Centroids of their points (camera frame): a new model's origin, and with the previous frame's the
  // first tracking's guess (as for a motion spawn: objects carried in fast move out of their mask).
  const int width = intrinsics_.width;
  std::vector<std::optional<Eigen::Vector3d>> centroids;
  for (const MaskInstance* inst : uncovered) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (size_t i : inst->pixels) {
      const double d = depth_m[i], x = double(i % size_t(width)), y = double(i / size_t(width));
      sum += Eigen::Vector3d((x - intrinsics_.cx) / intrinsics_.fx * d, (y - intrinsics_.cy) / intrinsics_.fy * d, d);
    }
    centroids.push_back(sum / double(inst->pixels.size()));  // instances have pixels with depth
  }
  const std::vector<InstanceCandidates::Seen> seen = instance_candidates_.update(uncovered, centroids, n);
  for (size_t k = 0; k < uncovered.size(); ++k) {
    if (seen[k].frames < sp.confirm_frames || int(live_models().size()) >= params_.lifecycle.max_active_models) continue;
    const int slot = free_slot(taken);
    if (slot < 0) break;
    taken |= 1u << slot;
    for (size_t i : uncovered[k]->pixels) {
      if (slots[i] != kNoSlot) --slot_pixels[slots[i]];
      slots[i] = static_cast<uint8_t>(slot);
      ++slot_pixels[size_t(slot)];
    }
    Eigen::Isometry3d T_camera_model = Eigen::Isometry3d::Identity();
    T_camera_model.translation() = *centroids[k];
    Model& m = create_model(slot, T_world_camera_ * T_camera_model);
    m.on_probation = false;
    if (seen[k].previous_centroid) {
      const Eigen::Vector3d step = *centroids[k] - *seen[k].previous_centroid;
      if (step.norm() <= params_.lifecycle.spawn_max_velocity_guess_m)
        m.last_motion = Eigen::Translation3d(-step) * Eigen::Isometry3d::Identity();
    }
    m.pixels = int(uncovered[k]->pixels.size());
    m.class_votes.add(uncovered[k]->class_name);
    spawned_slots.push_back(slot);
    char share[32];
    std::snprintf(share, sizeof share, "%.1f%%", 100.0 * double(uncovered[k]->pixels.size()) / double(n));
    out.events.push_back("frame " + std::to_string(frame_) + ": spawned model " + std::to_string(m.id) + " from a " +
                         uncovered[k]->class_name + " instance seen in " + std::to_string(seen[k].frames) + " frames (" + share +
                         " of the image)");
  }
}

// Non-rigid movers (LifecycleParams::rigidity_trial_frames): a young object model whose motion
// leaves too much of its own label unexplained in too many frames of its trial is dropped; its
// label's pixels become mover pixels.
void CoFusion::drop_nonrigid(const std::vector<Model*>& order, const std::vector<uint8_t>& seg_labels,
                             const std::vector<int>& labelled, const std::vector<int>& explained,
                             std::vector<uint8_t>& slots, CoFusionFrame& out) {
  const LifecycleParams& p = params_.lifecycle;
  for (size_t k = 1; k < order.size(); ++k) {
    Model& m = *order[k];
    const double fraction = labelled[k] > 0 ? double(explained[k]) / double(labelled[k]) : 0.0;
    if (m.state != ModelState::kActive || !m.tracked || frame_ - m.first_frame > p.rigidity_trial_frames) continue;
    if (!m.tracking.failed && fraction >= p.rigid_min_explained_fraction) continue;
    if (++m.rigidity_failures < p.rigidity_max_failures) continue;
    for (size_t i = 0; i < slots.size(); ++i)
      if (size_t(seg_labels[i]) == k || slots[i] == m.slot) slots[i] = kMoverSlot;
    m.state = ModelState::kInactive;
    m.slot = kRemovedSlot;
    char why[96];
    std::snprintf(why, sizeof why, "its motion explained %.0f%% of its pixels", 100.0 * fraction);
    out.events.push_back("frame " + std::to_string(frame_) + ": dropped model " + std::to_string(m.id) +
                         " (not rigid: " + (m.tracking.failed ? std::string("tracking failed") : std::string(why)) +
                         " in " + std::to_string(m.rigidity_failures) + " frames of its first " +
                         std::to_string(frame_ - m.first_frame) + ")");
  }
}

// Mover regions (LifecycleParams::mover_min_overlap): the outlier components of this frame's
// segmentation (components_) that overlap the previous frame's mover pixels enough; their pixels
// become mover pixels. Returns per component whether it is a mover.
std::vector<char> CoFusion::mark_movers(uint8_t outlier, std::vector<uint8_t>& slots) const {
  const size_t width = size_t(intrinsics_.width);
  std::vector<char> mover(components_.components.size(), 0);
  if (slots_.size() != slots.size()) return mover;
  std::vector<int64_t> overlap(mover.size(), 0);
  for (const auto& run : components_.runs)
    if (run.component >= 0 && run.value == outlier)
      for (int x = run.x0; x < run.x1; ++x) overlap[size_t(run.component)] += slots_[size_t(run.y) * width + size_t(x)] == kMoverSlot;
  for (size_t c = 0; c < mover.size(); ++c) {
    const auto& info = components_.components[c];
    mover[c] = info.value == outlier && overlap[c] > 0 &&
               double(overlap[c]) >= params_.lifecycle.mover_min_overlap * double(info.pixels);
  }
  for (const auto& run : components_.runs)
    if (run.component >= 0 && mover[size_t(run.component)])
      for (int x = run.x0; x < run.x1; ++x) slots[size_t(run.y) * width + size_t(x)] = kMoverSlot;
  return mover;
}

// Tries to align model m (inactive, or an object that lost every pixel this frame) with the
// region labelled `slot`, tracked with the region's pixels only, from two starts: its last
// orientation relative to the camera with its centre on the region's centroid, and where it was
// last seen (an object that left and comes back the same way, or the camera looking back at it).
// The start whose alignment has the most inliers wins if it passes the thresholds.
bool CoFusion::try_reactivate(Model& m, int slot, const Eigen::Vector3d& centroid_camera) {
  const std::vector<Surfel> surfels = m.surfels.download(m.stream);
  if (surfels.empty()) return false;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Surfel& s : surfels) centre += Eigen::Vector3d(s.px, s.py, s.pz);
  centre /= double(surfels.size());
  std::vector<Eigen::Isometry3d> starts;  // T_camera_model
  starts.push_back(T_world_camera_.inverse() * m.surfels.T_world_model);
  starts.back().translation() += centroid_camera - starts.back() * centre;
  if (m.T_world_model_last_seen) starts.push_back(T_world_camera_.inverse() * *m.T_world_model_last_seen);

  PredictionParams prediction;
  prediction.min_confidence = params_.slam.fusion.stable_confidence;
  const LifecycleParams& p = params_.lifecycle;
  std::optional<std::pair<TrackingResult, Eigen::Isometry3d>> best;
  for (const Eigen::Isometry3d& T_camera_model : starts) {
    m.stream.run([&](gpu::CommandList& c) {
      surfels_.predict(c, m.surfels, T_camera_model, m.prediction, prediction, frame_);
      motion_.mask_levels(c, live_.levels, m.masked, labels_, 1u << slot);
    });
    const TrackingResult r = m.tracker.track(m.stream, m.masked, m.prediction.levels, Eigen::Isometry3d::Identity());
    if (r.failed || r.inlier_ratio < p.reactivate_min_inlier_ratio || r.icp_rms_m > p.reactivate_max_rms_m) continue;
    if (!best || r.inlier_ratio > best->first.inlier_ratio) best.emplace(r, T_camera_model);
  }
  if (!best) return false;
  const auto& [r, T_camera_model] = *best;
  m.surfels.T_world_model = T_world_camera_ * r.T_reference_live.inverse() * T_camera_model;
  m.state = ModelState::kActive;
  m.slot = slot;
  m.tracking = r;
  m.tracked = true;
  m.last_motion = Eigen::Isometry3d::Identity();
  m.unseen_frames = 0;
  m.last_frame = frame_;
  return true;
}

// Moves every surfel of `gone` into `keep` (expressed in keep's frame) and deletes `gone`.
void CoFusion::merge_into(Model& keep, Model& gone, CoFusionFrame& out, const std::string& why) {
  gone.stream.wait_idle();
  std::vector<Surfel> moved = gone.surfels.download(gone.stream);
  transform_surfels(moved, keep.surfels.T_world_model.inverse() * gone.surfels.T_world_model);
  std::vector<Surfel> all = keep.surfels.download(keep.stream);
  all.insert(all.end(), moved.begin(), moved.end());
  // Within keep's capacity limit (SurfelModel::make_room): the least confident go.
  const unsigned pixels = unsigned(intrinsics_.width) * unsigned(intrinsics_.height);
  const unsigned most = keep.surfels.limit(pixels, params_.slam.fusion.max_surfels);
  if (all.size() > most) {
    keep.culled += static_cast<unsigned>(all.size() - most);
    keep_most_confident(all, most);
  }
  keep.surfels.upload(keep.stream, all);
  keep.class_votes.merge(gone.class_votes);
  out.events.push_back("frame " + std::to_string(frame_) + ": merged model " + std::to_string(gone.id) + " into " +
                       std::to_string(keep.id) + " (" + why + ")");
  gone.state = ModelState::kInactive;
  gone.slot = kRemovedSlot;
}

void CoFusion::retire(Model& m, CoFusionFrame& out) {
  m.stream.wait_idle();
  const std::vector<Surfel> surfels = m.surfels.download(m.stream);
  const auto stable = static_cast<unsigned>(std::count_if(surfels.begin(), surfels.end(), [&](const Surfel& s) {
    return s.confidence >= params_.slam.fusion.stable_confidence;
  }));
  m.state = ModelState::kInactive;
  const bool keep = stable >= params_.lifecycle.min_stable_surfels;
  m.slot = keep ? kInactiveSlot : kRemovedSlot;
  out.events.push_back("frame " + std::to_string(frame_) + ": model " + std::to_string(m.id) + " left the view (" +
                       std::to_string(stable) + " stable surfels): " + (keep ? "inactive" : "deleted"));
}

std::vector<ModelSnapshot> CoFusion::models() const {
  std::vector<ModelSnapshot> out;
  for (const auto& m : models_) {
    ModelSnapshot s;
    s.id = m->id;
    s.state = m->state;
    s.model = &m->surfels;
    s.first_frame = m->first_frame;
    s.last_frame = m->last_frame;
    s.class_name = m->id == 0 ? "background" : "object";
    if (const auto best = m->class_votes.best(); best && m->id != 0) {
      s.class_name = best->first;
      s.class_confidence = best->second;
    }
    s.trajectory = m->seen_trajectory;
    out.push_back(std::move(s));
  }
  std::sort(out.begin(), out.end(), [](const ModelSnapshot& a, const ModelSnapshot& b) { return a.id < b.id; });
  return out;
}

}  // namespace cofusion::slam
