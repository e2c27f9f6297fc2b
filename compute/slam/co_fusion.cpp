#include "slam/co_fusion.h"
#include "slam/co_fusion_model.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <numeric>
#include <span>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_group.h>

#include "common/se3.h"
#include "common/window_count.h"
#include "segmentation/depthless_labels.h"
#include "shared/depth_noise.h"
#include "slam/texture_tiles.h"

namespace cofusion::slam {
using namespace internal;  // the label slots (co_fusion_model.h)
namespace {
using Clock = std::chrono::steady_clock;
double ms_between(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

// Mean alignment cost per residual: point-to-plane squared plus lambda times photometric squared
// (sums of squares and counts of each term).
double mean_cost(double icp_r2, double icp_n, double rgb_r2, double rgb_n, double lambda) {
  const double n = icp_n + (lambda > 0 ? rgb_n : 0.0);
  return n > 0 ? (icp_r2 + lambda * rgb_r2) / n : 0.0;
}

// The n pixels' depth where `keep(pixel index)` holds, 0 (no reading) elsewhere (a template: it
// runs per pixel, every frame with excluded pixels).
template <typename Keep>
std::vector<float> depth_where(const float* depth_m, size_t n, const Keep& keep) {
  std::vector<float> depth(depth_m, depth_m + n);
  for (size_t i = 0; i < n; ++i)
    if (!keep(i)) depth[i] = 0.0f;
  return depth;
}

// The same for a tracking's last iteration.
double mean_alignment_cost(const TrackingResult& t, double lambda) {
  return mean_cost(t.icp_rms_m * t.icp_rms_m * t.icp_inliers, t.icp_inliers, t.rgb_rms * t.rgb_rms * t.rgb_residuals,
                   t.rgb_residuals, lambda);
}

// A tracking's last iteration's cost over the live pixels that could meet its model: each pair
// at its mean cost per residual, each such pixel without a pair at `unpaired` (a truncated cost).
double truncated_alignment_cost(const TrackingResult& t, double lambda, double unpaired) {
  const double comparable = std::max<double>(t.icp_inliers, t.valid_live_pixels - t.occluding_live_pixels);
  return mean_alignment_cost(t, lambda) * t.icp_inliers + unpaired * (comparable - t.icp_inliers);
}

// Bounding rectangle of each slot's pixels in a label map (empty for slots without pixels).
std::vector<PixelRect> slot_rects(const std::vector<uint8_t>& slots, int width, int height) {
  std::vector<PixelRect> rects(256, PixelRect{width, height, 0, 0});
  for (int y = 0; y < height; ++y) {
    const uint8_t* row = slots.data() + size_t(y) * size_t(width);
    for (int x = 0; x < width;) {  // one update per run of equal slots
      const uint8_t slot = row[x];
      const int x0 = x;
      while (x < width && row[x] == slot) ++x;
      PixelRect& r = rects[slot];
      r.x0 = std::min(r.x0, x0), r.x1 = std::max(r.x1, x);
      r.y0 = std::min(r.y0, y), r.y1 = std::max(r.y1, y + 1);
    }
  }
  for (PixelRect& r : rects)
    if (r.empty()) r = PixelRect{};
  return rects;
}

}  // namespace

const char* to_string(ModelState state) { return state == ModelState::kActive ? "active" : "inactive"; }
const char* to_string(CameraState state) {
  switch (state) {
    case CameraState::kTracking: return "tracking";
    case CameraState::kLost: return "lost";
    case CameraState::kRecovered: return "recovered";
    case CameraState::kRefused: return "refused";
  }
  return "?";
}


// ---------------------------------------------------------------------------------------------
CoFusion::CoFusion(gpu::Context& ctx, const Intrinsics& intrinsics, const CoFusionParams& params)
    : ctx_(ctx),
      overlap_host_work_(params.host_overlap == CoFusionParams::HostOverlap::kAuto ? !ctx.is_software()
                                                                                  : params.host_overlap == CoFusionParams::HostOverlap::kOn),
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
  if (life.rigidity_trial_frames < 0 || life.rigidity_max_failures < 1 || life.coast_frames < 0 || life.coast_border_px < 0 ||
      !(life.rigid_min_explained_fraction >= 0 && life.rigid_min_explained_fraction <= 1) ||
      !(life.mover_min_overlap > 0 && life.mover_min_overlap <= 1))
    throw Error("lifecycle: rigidity_trial_frames, coast_frames and coast_border_px must be >= 0, rigidity_max_failures >= 1, "
                "rigid_min_explained_fraction in [0, 1], mover_min_overlap in (0, 1]");
  const SemanticParams& sem = params.semantic;
  if (sem.confirm_frames < 1 || !(sem.min_instance_area_fraction >= 0 && sem.min_instance_area_fraction < 1) ||
      !(sem.join_min_iou > 0 && sem.join_min_iou <= 1) ||
      !(sem.resting_max_unexplained_fraction >= 0 && sem.resting_max_unexplained_fraction <= 1))
    throw Error("semantic: confirm_frames must be >= 1, min_instance_area_fraction in [0, 1), join_min_iou in (0, 1], "
                "resting_max_unexplained_fraction in [0, 1]");
  main_stream_.set_profile_group("frame");
  unwarper_ = ColourUnwarper(params.slam.rolling_shutter);
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
  tbb::parallel_for(tbb::blocked_range<size_t>(0, slots.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) wide[i] = slots[i] == kNoSlot ? 0xFFFFFFFFu : slots[i];
  });
  // No wait here: the label map's readers (fusion, duplicate removal, re-activation) wait for the
  // copy on the GPU (Stream::wait_next_on_gpu), the next frame's through the preprocessing.
  labels_uploaded_ = main_stream_.upload_submitted(labels_, wide.data(), wide.size() * sizeof(uint32_t));
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
  if (params_.motion_segmentation)
    motion_.mask_levels(c, live_.levels, m.masked, labels_, tracked_slot_mask(m, resting_slots_), m.track_rect);
  // Tracking's submissions are not otherwise ordered after this one: the host waits.
  m.stream.wait(m.stream.submit(std::move(c), std::span(&preprocessed, 1)));
}

// The label slots whose pixels model m tracks with (bit s for slot s): its own; for the background
// also the unclaimed pixels when they are many, and the pixels of the resting models (`resting`),
// whose surfels are still its own.
uint32_t CoFusion::tracked_slot_mask(const Model& m, uint32_t resting) const {
  if (m.id != 0) return 1u << m.slot;
  const bool unclaimed = unclaimed_fraction_ > params_.lifecycle.background_tracks_unclaimed_above;
  return (1u << m.slot) | (unclaimed ? 1u << kUnclaimedSlot : 0u) | resting;
}

// Model m's tracking from `guess`, with its masked live pixels (every live pixel without motion
// segmentation: there is nothing to mask).
TrackingJob CoFusion::tracking_job(Model& m, const Eigen::Isometry3d& guess) {
  return TrackingJob{&m.tracker, params_.motion_segmentation ? &m.masked : &live_.levels, &m.prediction.levels, guess,
                     m.track_rect, m.stream.profile_group(), {}};
}

// Whether the image's border cuts model m: its working rectangle reaches within
// LifecycleParams::coast_border_px of it (coasting and the outline term's choice).
bool CoFusion::cut_by_border(const Model& m) const {
  return m.track_rect.near_border(intrinsics_.width, intrinsics_.height, params_.lifecycle.coast_border_px);
}

// An object cut by the image's border tracks without its outline term, unless
// LifecycleParams::object_outline_at_border; its rest test then compares the same terms.
void CoFusion::choose_object_terms(Model& m) {
  const LifecycleParams& life = params_.lifecycle;
  const bool outline = life.object_outline_photometric && (life.object_outline_at_border || !cut_by_border(m));
  const bool skip_rim = life.object_photometric_skip_rim && !outline;
  if (m.tracker.params().outline_photometric == outline && m.tracker.params().photometric_skip_rim == skip_rim) return;
  TrackerParams t = m.tracker.params();
  t.outline_photometric = outline;
  t.photometric_skip_rim = skip_rim;
  m.tracker.set_params(t);
}

// Tracks the models with their own live pixels, all in lockstep on the main stream: one
// submission per Gauss-Newton iteration for all of them, which on a discrete GPU costs little more
// than one model's.
void CoFusion::track(const std::vector<Model*>& models) {
  std::vector<TrackingJob> jobs;
  std::vector<gpu::TimelinePoint> predicted;  // each model's prediction and masks, on its own stream
  for (Model* m : models) {
    if (m->id != 0) choose_object_terms(*m);
    jobs.push_back(tracking_job(*m, params_.slam.constant_velocity_guess ? m->last_motion : Eigen::Isometry3d::Identity()));
    predicted.push_back(m->stream.last_submitted());
  }
  track_together(main_stream_, jobs, predicted);
  track_second_starts(models, jobs);
  for (size_t i = 0; i < models.size(); ++i) {
    Model& m = *models[i];
    m.tracking = std::move(jobs[i].result);
    m.guess_from_centroid_step = false;
    m.tracked = true;
    m.motion = m.tracking.failed ? jobs[i].T_reference_live_guess : m.tracking.T_reference_live;
  }
}

// A second start from no motion, for the models of `jobs` (tracked from their guesses) that need
// one; where second_start_wins, its result replaces the job's. For a new model, whose velocity
// guess is its region's centroid step (off when the region grew or shrank between the frames), the
// alignment with the lower cost per residual is kept (the inlier counts mislead: a wrong pose can
// pair more pixels); for an object cut by the border, the start from no motion where its truncated
// cost is clearly lower (LifecycleParams::border_unpaired_cost, border_still_min_gain). The
// border's second start runs the camera's iterations (fewer than an object's): it is there to find
// another basin.
void CoFusion::track_second_starts(const std::vector<Model*>& models, std::vector<TrackingJob>& jobs) {
  const auto needs_one = [&](size_t i) {
    const Model& m = *models[i];
    const bool at_border = params_.lifecycle.border_unpaired_cost > 0 && m.id != 0 && cut_by_border(m);
    return (m.guess_from_centroid_step || at_border) && !jobs[i].T_reference_live_guess.isApprox(Eigen::Isometry3d::Identity());
  };
  std::vector<TrackingJob> still;
  std::vector<size_t> again;
  for (size_t i = 0; i < models.size(); ++i)
    if (needs_one(i)) {
      still.push_back(tracking_job(*models[i], Eigen::Isometry3d::Identity()));
      if (!models[i]->guess_from_centroid_step) still.back().iterations_per_level = params_.slam.tracker.iterations_per_level;
      again.push_back(i);
    }
  if (still.empty()) return;
  track_together(main_stream_, still);
  for (size_t k = 0; k < again.size(); ++k)
    if (second_start_wins(*models[again[k]], jobs[again[k]].result, still[k].result))
      jobs[again[k]].result = still[k].result;
}

// Whether model m's tracking from no motion (`still`) replaces the one from its guess (`moved`), as
// track() explains.
bool CoFusion::second_start_wins(const Model& m, const TrackingResult& moved, const TrackingResult& still) const {
  if (still.failed) return false;
  if (moved.failed) return true;
  const TrackerParams& tp = m.tracker.params();
  const double lambda = tp.use_photometric ? tp.photometric_weight : 0.0;
  const double moved_mean = mean_alignment_cost(moved, lambda), still_mean = mean_alignment_cost(still, lambda);
  if (m.guess_from_centroid_step) return still_mean < moved_mean;
  const LifecycleParams& life = params_.lifecycle;
  const double unpaired = life.border_unpaired_cost * 0.5 * (moved_mean + still_mean);
  return truncated_alignment_cost(still, lambda, unpaired) <
         (1.0 - life.border_still_min_gain) * truncated_alignment_cost(moved, lambda, unpaired);
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
    compute_residuals({&bg});
  }
  return true;
}

// Once every model is tracked: an object whose pixels staying where it is in the world
// (`camera_motion`, the background's) explain as well as its tracked motion stays (RestParams).
// Then the per-pixel alignment cost of each model's motion over its residual rectangle (the
// segmentation's input). All models' rest tests are one submission, their residuals another.
void CoFusion::settle_models(const std::vector<Model*>& models, const Eigen::Isometry3d& camera_motion) {
  std::vector<Model*> testing;
  for (Model* m : models)
    if (m->id != 0 && !m->resting && params_.rest.prefer_rest && !m->tracking.failed && params_.motion_segmentation)
      testing.push_back(m);
  if (!testing.empty()) {
    gpu::CommandList cmd = main_stream_.begin();
    std::vector<uint32_t> groups;
    for (Model* m : testing) {
      const TrackerParams& tp = m->tracker.params();
      const TrackingResult& t = m->tracking;
      // The scales tracking would use next, at its last iteration's exposure gain.
      const IterationScales scales = next_iteration_scales(tp, t, t.live_intensity_gain);
      cmd.set_profile_group(m->stream.profile_group());
      groups.push_back(m->tracker.record_reduction(cmd, m->masked[0], m->prediction.levels[0], camera_motion,
                                                   m->track_rect, scales));
    }
    std::vector<const float*> partials;
    for (size_t k = 0; k < testing.size(); ++k) partials.push_back(testing[k]->tracker.record_readback(cmd, groups[k]));
    main_stream_.wait(main_stream_.submit(std::move(cmd)));
    for (size_t k = 0; k < testing.size(); ++k)
      rest_if_still_fits(*testing[k], camera_motion, Tracker::add_partials(partials[k], groups[k]));
  }
  for (Model* m : models) {
    const LifecycleParams& life = params_.lifecycle;
    const bool coast = m->tracking.failed && m->id != 0 && m->coasted_frames < life.coast_frames && cut_by_border(*m);
    m->coasted_frames = m->tracking.failed ? m->coasted_frames + 1 : 0;
    if (!coast)
      m->last_motion = m->tracking.failed ? Eigen::Isometry3d::Identity() : m->velocity_motion.value_or(m->motion);
    m->T_prediction_live = m->motion;
  }
  if (params_.motion_segmentation) compute_residuals(models);
}

// The rest test of one object from the sums of its pixels at `camera_motion` (`still`). The
// tracked motion's fit is tracking's last iteration's (at the pose before its final, converged
// step), so only rest needs a reduction of its own.
void CoFusion::rest_if_still_fits(Model& m, const Eigen::Isometry3d& camera_motion, const LinearSystemSums& still) {
  const RestParams& rest = params_.rest;
  const TrackerParams& tp = m.tracker.params();
  const double lambda = tp.use_photometric ? tp.photometric_weight : 0.0;
  const TrackingResult& t = m.tracking;
  const double moved_n = t.icp_inliers;
  const double moved_cost = mean_alignment_cost(t, lambda);
  const double still_cost = mean_cost(still.icp[27], still.icp[28], still.rgb[27], still.rgb[28], lambda);
  if (moved_n > 0 && still.icp[28] >= rest.min_correspondence_fraction * moved_n &&
      still_cost <= (1.0 + rest.max_cost_increase) * moved_cost)
    m.motion = camera_motion;
}

// The per-pixel residuals of the live frame against each model's prediction (the live frame
// taken to the prediction's view by T_prediction_live), over its residual rectangle, read back:
// one submission for all models.
void CoFusion::compute_residuals(const std::vector<Model*>& models) {
  const size_t row_floats = size_t(intrinsics_.width) * 4;
  std::vector<gpu::TimelinePoint> predicted;  // each model's prediction, on its own stream
  for (Model* m : models) predicted.push_back(m->stream.last_submitted());
  gpu::CommandList cmd = main_stream_.begin();
  for (Model* m : models) {
    cmd.set_profile_group(m->stream.profile_group());
    motion_.residuals(cmd, live_.levels[0], m->prediction.levels[0], m->T_prediction_live, m->residuals,
                      m->residual_rect, m->tracking.live_intensity_gain);
  }
  for (Model* m : models) {
    const size_t offset = size_t(m->residual_rect.y0) * row_floats * sizeof(float);
    const size_t bytes = size_t(m->residual_rect.height()) * row_floats * sizeof(float);
    m->residual_rows = static_cast<const float*>(
        gpu::record_download(main_stream_.context(), cmd, m->residuals, bytes, offset, m->residuals_readback));
  }
  main_stream_.wait(main_stream_.submit(std::move(cmd), predicted));
  for (Model* m : models) m->settled = true;
}

// The segmentation's input for model m: per-pixel alignment cost in metres, NaN = no geometry.
void CoFusion::model_costs(const Model& m, const float* depth_m, std::vector<float>& costs) const {
  const size_t n = slots_.size();
  const PixelRect& rect = m.residual_rect;
  const size_t width = size_t(intrinsics_.width);
  // Pixel i's residuals (4 floats); only pixels of the residual rectangle's rows are read back.
  const auto residual = [width](const Model& model, size_t i) {
    return model.residual_rows + 4 * (i - size_t(model.residual_rect.y0) * width);
  };
  // Outside its residual rectangle the model has no geometry; only the rectangle is read.
  costs.assign(n, kNaN);
  if (!m.settled) return;  // not tracked this frame (the camera was relocalised): no evidence
  const MotionCostParams& p = params_.costs;
  const bool background = m.id == 0;
  const float z_ref = p.noise_reference_depth_m;
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
  const Model& bg = *models_.front();
  const std::optional<WindowCount> with_geometry =
      background ? std::nullopt
                 : std::optional<WindowCount>(std::in_place, rect.width(), rect.height(), [&](int x, int y) {
                     const size_t i = size_t(y + rect.y0) * width + size_t(x + rect.x0);
                     return residual(m, i)[3] == MOTION_STATUS_ASSOCIATED;
                   });
  tbb::parallel_for(tbb::blocked_range<int>(rect.y0, rect.y1, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (size_t i = size_t(y) * width + size_t(rect.x0); i < size_t(y) * width + size_t(rect.x1); ++i) {
        const float* v = residual(m, i);  // (point-to-plane m, live z - predicted z m, |dI|, status)
        if (!background && v[3] == MOTION_STATUS_NO_MODEL) {
          const float* b = residual(bg, i);
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
          const float scale = gpu_layout::depth_noise_scale(z, z_ref);
          costs[i] = std::min(v[0] * scale + photometric_m * v[2], p.max_cost_m);
        }
      }
  });
}

void CoFusion::fuse_model(Model& m, const std::vector<int>& duplicate_slots, const PixelRect& fuse_rect,
                          uint32_t also_slots) {
  const Eigen::Isometry3d T_camera_model = T_world_camera_.inverse() * m.surfels.T_world_model;
  m.stream.wait_next_on_gpu(labels_uploaded_);
  for (int duplicate_slot : duplicate_slots)
    surfels_.remove_region(m.stream, m.surfels, live_, T_camera_model, labels_, static_cast<unsigned>(duplicate_slot),
                           params_.lifecycle.duplicate_margin_rel);
  if (m.tracking.failed || m.motion_refused) return;  // a guessed pose would corrupt the model
  const FusionStats stats =
      surfels_.fuse(m.stream, m.surfels, live_, T_camera_model, frame_, params_.slam.fusion,
                    params_.motion_segmentation ? labels_ : nullptr, static_cast<unsigned>(m.slot),
                    m.id == 0 ? std::nullopt : std::optional(fuse_rect), float(m.tracking.live_intensity_gain), also_slots);
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
CoFusionFrame CoFusion::process(const float* depth_m, const uint8_t* input_rgb, const SemanticFrame* semantic) {
  CoFusionFrame out;
  out.frame = frame_;
  const int width = intrinsics_.width, height = intrinsics_.height;
  const Clock::time_point colour_start = Clock::now();
  const uint8_t* rgb = without_rolling_shutter(input_rgb);
  if (params_.camera_check.photometric_tile_cap > 0 && !models_.empty())
    models_.front()->tracker.set_photometric_tile_weights(
        texture_tile_weights(rgb, width, height, params_.camera_check.photometric_tile_cap));
  const Clock::duration colour_time = Clock::now() - colour_start;
  const std::vector<uint8_t> excluded = begin_semantic_frame(semantic);
  frame_rgb_ = rgb;
  frame_excluded_ = &excluded;
  previous_samples_.reset();
  // The keyframes' pose of the camera, where the camera check will pull towards it: on a CPU job
  // while the GPU preprocesses and tracks.
  tbb::task_group keyframe_pose_job;
  std::optional<KeyframePose> keyframe_pose;
  frame_keyframe_pose_ = nullptr;
  frame_pull_gain_ = keyframe_pull_gain(excluded);
  if (frame_ > 0 && !lost_ && params_.camera_check.enabled && keyframes_.size() > 0 && frame_pull_gain_ > 0) {
    keyframe_pose_job.run([&, depth_m] { keyframe_pose = keyframe_camera_pose(depth_m); });
    frame_keyframe_pose_ = [&] {
      keyframe_pose_job.wait();
      return keyframe_pose;
    };
  }
  // The stages start here; the colour's resampling and tile weights count in the upload.
  auto lap = Clock::now() - colour_time;
  const auto stage = [&](const char* name) {
    const auto now = Clock::now();
    out.stage_ms.emplace_back(name, ms_between(lap, now));
    lap = now;
  };
  std::vector<Model*> active = live_models();
  for (Model* m : active) m->tracked = false, m->settled = false, m->motion_refused = false, m->tracking = {}, m->velocity_motion.reset();
  set_work_rects(active);
  resting_slots_ = resting_slots(active);
  // The inputs' upload opens the preprocessing's submission (no submission of its own); the
  // previous frame's work on the main stream has finished with them.
  main_stream_.wait_idle();
  gpu::CommandList pre = main_stream_.begin();
  live_.record_upload(main_stream_.context(), pre, depth_m, rgb);
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
      superpixels = segmenter_.superpixels(rgb, depth_m, width, height, overlap_host_work_);
      sp_end = Clock::now();
    });
  // The frame's keyframe encoding: for relocalisation now when lost, else for the database later.
  FrameEncoding encoding;
  const auto encode = [&] { encoding = keyframes_.encode(rgb, depth_m, width, height); };
  if (lost_)
    encode();
  else
    cpu_jobs.run(encode);

  preprocessor_.record_frame(pre, live_, kernels::FramePyramid::kUploadMetresPerUnit, preprocess_);
  const gpu::TimelinePoint preprocessed = main_stream_.submit(std::move(pre));
  main_stream_.wait(preprocessed);
  stage("preprocess");

  const CameraState camera = track_or_relocalise(active, depth_m, rgb, encoding, preprocessed, out, stage);
  out.camera_state = camera;
  const Clock::time_point gpu_end = Clock::now();
  update_poses(active, out);
  // Motion mode uses instances for class votes only: no pass over the image for them.
  if (semantic_ && camera != CameraState::kLost && params_.semantic.mode != SegmentationMode::kMotion)
    semantic_ = carried_to_this_frame(*semantic_, depth_m);

  std::vector<int> spawned_slots;
  cpu_jobs.wait();
  keyframe_pose_job.wait();
  if (segmenting && camera == CameraState::kLost) {
    // Nothing is known of this frame's motion: no segmentation, no fusion (every model's tracking
    // counts as failed), and the previous labels stay for the next frame.
  } else if (segmenting) {
    out.superpixels_ms = ms_between(sp_start, sp_end);
    out.superpixels_overlap_ms = std::max(0.0, ms_between(std::max(sp_start, gpu_start), std::min(sp_end, gpu_end)));
    const auto seg_start = Clock::now();
    // The labels the camera tracked with, for CameraRetrackParams (only when it is on).
    const std::vector<uint8_t> tracked_slots = params_.retrack.min_taken_fraction > 0 ? slots_ : std::vector<uint8_t>{};
    std::vector<Model*> were_resting;
    for (Model* m : active)
      if (m->resting) were_resting.push_back(m);
    segment(*superpixels, depth_m, rgb, excluded, active, out, spawned_slots);
    out.segment_ms = ms_between(seg_start, Clock::now());
    track_woken(were_resting, out);
    if (camera == CameraState::kTracking) retrack_camera(tracked_slots, out);
  } else {
    label_all_background(depth_m, excluded);
  }
  stage("segment");
  // What the frame leaves that needs no fused model, on a CPU job while the models fuse.
  const auto keep = [&] {
    keep_frame(camera, encoding, depth_m, rgb, segmenting && camera != CameraState::kLost ? &*superpixels : nullptr,
               excluded, out);
  };
  tbb::task_group keep_job;
  if (overlap_host_work_) keep_job.run(keep);
  fuse_models(spawned_slots);
  stage("fuse");
  if (overlap_host_work_)
    keep_job.wait();
  else
    keep();
  finish_frame(camera, out);
  stage("finish");
  return out;
}

// The frame's colour as its middle row's pose would have seen it (RollingShutterParams), for a
// camera turning as it did over the last frame; the input itself without a rolling shutter, on
// the first frame and while the camera is lost.
const uint8_t* CoFusion::without_rolling_shutter(const uint8_t* rgb) {
  const bool have_motion = frame_ > 0 && !lost_ && !models_.empty();
  return unwarper_.unwarp(rgb, intrinsics_, have_motion ? models_.front()->last_motion : Eigen::Isometry3d::Identity(),
                          have_motion);
}

// Predicts and tracks every active model, or, while the camera is lost, tries to relocalise it
// (the first frame does neither). `stage` closes a timed stage.
CameraState CoFusion::track_or_relocalise(const std::vector<Model*>& active, const float* depth_m, const uint8_t* rgb,
                                          const FrameEncoding& encoding, const gpu::TimelinePoint& preprocessed,
                                          CoFusionFrame& out, const std::function<void(const char*)>& stage) {
  if (frame_ == 0) return CameraState::kTracking;
  if (!lost_) {
    for_each_model(active, [&](Model& m) { predict_model(m, preprocessed); });
    stage("predict");
    std::string refusal;
    const CameraState camera = track_models(active, depth_m, refusal, stage);
    if (!refusal.empty()) out.events.push_back("frame " + std::to_string(frame_) + ": " + refusal);
    stage("residuals");
    return camera;
  }
  const std::vector<float> depth_not_excluded = depth_outside_excluded(depth_m);
  const auto features = keyframes_.features(rgb, depth_not_excluded.data(), intrinsics_);
  const CameraState camera =
      relocalise(*active.front(), encoding, features) ? CameraState::kRecovered : CameraState::kLost;
  if (camera == CameraState::kRecovered) out.events.push_back("frame " + std::to_string(frame_) + ": camera relocalised");
  stage("relocalise");
  return camera;
}

// Checks the frame's instance masks and returns its excluded pixels (SemanticParams::exclude,
// empty without masks): they are mover pixels from the start, so that no model tracks with them
// this frame, and again after the segmentation.
std::vector<uint8_t> CoFusion::begin_semantic_frame(const SemanticFrame* semantic) {
  std::vector<uint8_t> excluded;
  semantic_ = semantic;
  if (!semantic) return excluded;
  check_semantic_frame(*semantic, size_t(intrinsics_.width) * intrinsics_.height);
  // Excluded pixels are where the masks saw their movers (grown by exclude_margin_px), not carried
  // to this frame as the instances are after tracking: the carrying follows the estimated motion
  // that the exclusion keeps movers out of, and where people fill the view that estimate can be off.
  excluded_pixels(*semantic, params_.semantic, excluded);
  if (!excluded.empty() && !params_.motion_segmentation)
    throw Error("excluding classes by their masks needs motion segmentation (not implemented for background-only runs)");
  if (!excluded.empty()) grow_mask(excluded, intrinsics_.width, params_.semantic.exclude_margin_px);
  if (mark_excluded(excluded, kMoverSlot, slots_)) upload_labels(slots_);
  return excluded;
}

// Masks made from an earlier frame, carried to this one by the camera's motion since (this frame's
// tracked pose). Masks from the previous frame follow the objects that moved since, too: a pixel
// the previous frame gave to a tracked object model is carried by that model's motion (older masks
// by the camera's alone: the models' motions are kept for one frame). Masks older than the pose
// history, or from a frame where the camera was lost, are taken as they are.
const SemanticFrame* CoFusion::carried_to_this_frame(const SemanticFrame& semantic, const float* depth_m) {
  const int age = semantic.age_frames;
  if (age <= 0 || age > int(camera_history_.size())) return &semantic;
  const std::optional<Eigen::Isometry3d>& T_world_made = camera_history_[camera_history_.size() - size_t(age)];
  if (!T_world_made) return &semantic;
  const Eigen::Isometry3d T_made_current = T_world_made->inverse() * T_world_camera_;
  std::vector<SlotMotion> object_motions;
  const size_t n = size_t(intrinsics_.width) * intrinsics_.height;
  if (age == 1 && slots_.size() == n)
    for (const auto& m : models_)
      if (m->id != 0 && m->state == ModelState::kActive && m->slot >= 0 && m->tracked && !m->tracking.failed &&
          !m->resting)
        object_motions.push_back({uint8_t(m->slot), m->motion});
  static const std::vector<uint8_t> kNoOwners;
  const std::vector<uint8_t>& owners = object_motions.empty() ? kNoOwners : slots_;  // no copy of the labels
  carried_semantic_ = carry_semantic_frame(semantic, depth_m, intrinsics_, T_made_current, owners, object_motions);
  return &carried_semantic_;
}

uint32_t CoFusion::resting_slots(const std::vector<Model*>& models) {
  uint32_t slots = 0;
  for (const Model* m : models)
    if (m->resting) slots |= 1u << m->slot;
  return slots;
}

// Where each model works this frame (see Model::track_rect).
void CoFusion::set_work_rects(const std::vector<Model*>& active) {
  const int width = intrinsics_.width, height = intrinsics_.height;
  const std::vector<PixelRect> rects = slot_rects(slots_, width, height);
  const PixelRect full = PixelRect::full(width, height);
  for (Model* m : active) {
    m->track_rect = m->id == 0 ? full : rects[size_t(m->slot)];
    m->residual_rect = m->id == 0 ? full : m->track_rect.grown(params_.costs.object_margin_px).clamped(width, height);
  }
}

// One task per model, each on its own stream: models run concurrently where the device has
// several queues, and their host-side work (recording, the 6x6 solves) overlaps everywhere.
template <typename Work>
void CoFusion::for_each_model(const std::vector<Model*>& models, const Work& work) {
  tbb::task_group jobs;
  for (Model* m : models) jobs.run([m, &work] { work(*m); });
  jobs.wait();
}

// Tracks every active model. The camera's (the background's) motion is checked against the
// previous frame (`refusal` says why when it was replaced); when its tracking fails and the
// previous frame cannot stand in, the camera is lost and every model holds still. Else each
// model's residuals are computed. Stages: "track" (every model's ICP), "check camera" (the
// camera's motion checked and pulled towards the keyframes), then the caller's "residuals".
CameraState CoFusion::track_models(const std::vector<Model*>& active, const float* depth_m, std::string& refusal,
                                   const std::function<void(const char*)>& stage) {
  Model& bg = *active.front();
  std::vector<Model*> moving;
  for (Model* m : active)
    if (!m->resting) moving.push_back(m);
  track(moving);
  stage("track");
  std::optional<CameraFits> fits;
  if (params_.camera_check.enabled && !previous_depth_m_.empty()) fits = camera_fits(bg, depth_m);
  retry_camera_tracking(bg, depth_m, fits);
  refusal = check_camera_motion(bg, depth_m, fits);
  stage("check camera");
  if (bg.tracking.failed) {
    lost_ = true;
    hold_still(active, bg.tracking.failure_reason);
    return CameraState::kLost;
  }
  const Eigen::Isometry3d camera_motion = bg.motion;
  // The previous frame's image where the camera's motion puts this frame's pixels (spawn
  // evidence), on a CPU job while the GPU tests rest and computes the residuals.
  tbb::task_group sampling;
  if (overlap_host_work_ && can_sample_previous()) {
    const Eigen::Isometry3d T_previous_current = camera_history_.back()->inverse() * camera_pose_after(bg.motion);
    sampling.run([this, depth_m, T_previous_current] { previous_samples_ = sample_previous(depth_m, T_previous_current); });
  }
  for (Model* m : active)
    if (m->resting) {  // stays where it is in the world; fuses when the background does
      m->tracked = true;
      m->tracking = bg.tracking;
      m->motion = camera_motion;
      m->motion_refused = bg.motion_refused;
    }
  settle_models(active, camera_motion);
  sampling.wait();
  return refusal.empty() ? CameraState::kTracking : CameraState::kRefused;
}

// How well the background's tracked motion, the constant-velocity guess and no motion explain the
// previous frame's depth (CameraCheckParams; needs a previous frame).
CameraFits CoFusion::camera_fits(const Model& bg, const float* depth_m) const {
  const CameraCheckParams& p = params_.camera_check;
  const auto fit = [&](const Eigen::Isometry3d& T) { return depth_fit(depth_m, previous_depth_m_.data(), intrinsics_, T, p); };
  CameraFits f;
  f.guess = params_.slam.constant_velocity_guess ? bg.last_motion : Eigen::Isometry3d::Identity();
  double by_guess = 0, still = 0;
  tbb::parallel_invoke([&] { f.tracked = fit(bg.motion); }, [&] { by_guess = fit(f.guess); },
                       [&] { still = fit(Eigen::Isometry3d::Identity()); });
  f.from_guess = by_guess >= still;
  f.start = std::max(by_guess, still);
  return f;
}

// CameraCheckParams::retry_photometric_weight: a failed or refused camera tracking is tried once
// more with the photometric term weighted differently; the retry is kept where it succeeds and
// fits the previous frame better. `fits` (none without a check) then holds the retry's fit.
void CoFusion::retry_camera_tracking(Model& bg, const float* depth_m, std::optional<CameraFits>& fits) {
  const CameraCheckParams& p = params_.camera_check;
  const TrackerParams primary = bg.tracker.params();
  if (p.retry_photometric_weight <= 0 || p.retry_photometric_weight == primary.photometric_weight) return;
  if (!bg.tracking.failed && (!fits || !fits->refused(p.min_fit_ratio))) return;
  const TrackingResult first = bg.tracking;
  const Eigen::Isometry3d first_motion = bg.motion;
  TrackerParams retry = primary;
  retry.photometric_weight = p.retry_photometric_weight;
  bg.tracker.set_params(retry);
  track({&bg});
  bg.tracker.set_params(primary);
  if (!bg.tracking.failed) {
    if (!fits) return;
    const double retry_fit = depth_fit(depth_m, previous_depth_m_.data(), intrinsics_, bg.motion, p);
    if (first.failed || retry_fit > fits->tracked) {
      fits->tracked = retry_fit;
      return;
    }
  }
  bg.tracking = first;
  bg.motion = first_motion;
}

// CameraCheckParams: the background's tracked motion against the previous frame's depth. A refused
// motion is replaced by the better-fitting of the slowed constant-velocity guess and no motion,
// unless the refused poses have agreed with each other for a few frames (tracked_poses_agree). A
// failed tracking is replaced the same way where the replacement fits at least min_fit_ratio
// times what the last frame's camera motion did (else the camera is lost). The background fuses
// nothing in a replaced frame. Returns why the motion was replaced (empty when it stands or the
// camera is lost).
std::string CoFusion::check_camera_motion(Model& bg, const float* depth_m, const std::optional<CameraFits>& fits) {
  const CameraCheckParams& p = params_.camera_check;
  if (!fits) return {};
  const CameraFits& f = *fits;
  const bool failed = bg.tracking.failed;
  if (!failed && f.refused(p.min_fit_ratio) && p.keyframe_pose_gain > 0)
    if (const auto features = frame_keyframe_pose(depth_m)) return take_keyframe_pose(bg, f, features->T_world_camera);
  // Agreement is counted over refused frames only (tracked_poses_agree keeps the count).
  const bool agree = !failed && f.refused(p.min_fit_ratio) && tracked_poses_agree(bg, depth_m, f);
  const CameraDecision decision = decide_camera_motion(f, failed, agree, last_camera_fit_, p);
  if (decision.verdict == CameraVerdict::kStands) {
    if (!failed) pull_towards_keyframes(bg, depth_m);
    last_camera_fit_ = f.tracked;
    refused_T_world_tracked_.reset();
    agreeing_refusals_ = 0;
    return {};
  }
  if (failed) refused_T_world_tracked_.reset(), agreeing_refusals_ = 0;
  if (decision.verdict == CameraVerdict::kLost) return {};
  const auto percent = [](double share) { return std::to_string(int(std::lround(100 * share))) + "%"; };
  const std::string why = failed ? "camera tracking failed (" + bg.tracking.failure_reason + ")"
                                 : "camera motion refused: it fits " + percent(f.tracked) + " of the previous frame's depth";
  bg.motion = decision.motion;
  if (failed) {
    bg.tracking = TrackingResult{};
    bg.tracking.T_reference_live = bg.motion;
  }
  bg.motion_refused = true;
  last_camera_fit_ = f.start;
  const std::string taken = (f.from_guess ? "the slowed constant-velocity guess " : "no motion ") + percent(f.start);
  return why + ", " + taken + " is taken and nothing is fused into the background";
}

// CameraCheckParams::keyframe_pose_gain: a refused motion replaced by its replacement moved part of
// the way towards the pose the keyframes' features give; the agreement count starts anew.
std::string CoFusion::take_keyframe_pose(Model& bg, const CameraFits& f, const Eigen::Isometry3d& T_world_features) {
  const CameraCheckParams& p = params_.camera_check;
  const Eigen::Isometry3d replacement = decide_camera_motion(f, false, false, last_camera_fit_, p).motion;
  bg.motion = motion_towards(replacement, T_world_camera_.inverse() * T_world_features, p.keyframe_pose_gain);
  bg.motion_refused = true;
  last_camera_fit_ = f.start;
  refused_T_world_tracked_.reset();
  agreeing_refusals_ = 0;
  char why[200];
  std::snprintf(why, sizeof why,
                "camera motion refused: it fits %d%% of the previous frame's depth; moved %.0f%% of the way towards the "
                "keyframes' features' pose, and nothing is fused into the background",
                int(std::lround(100 * f.tracked)), 100 * p.keyframe_pose_gain);
  return why;
}

// CameraCheckParams::keyframe_pull_gain: a camera motion that stands moves towards the keyframes'
// features' pose (where enough matches support it) by the gain times the share of excluded
// pixels; the next frame's guess continues the tracked motion.
void CoFusion::pull_towards_keyframes(Model& bg, const float* depth_m) const {
  if (frame_pull_gain_ <= 0) return;
  const auto features = frame_keyframe_pose(depth_m);
  if (!features || features->inliers < params_.camera_check.keyframe_pull_min_inliers) return;
  bg.velocity_motion = bg.motion;
  bg.motion = motion_towards(bg.motion, T_world_camera_.inverse() * features->T_world_camera, frame_pull_gain_);
}

// The frame's fraction of the way towards the keyframes' pose (CameraCheckParams::keyframe_pull_gain
// times the share of excluded pixels, at most 1; 0 without masks).
double CoFusion::keyframe_pull_gain(const std::vector<uint8_t>& excluded) const {
  if (excluded.empty()) return 0;
  const auto n = std::count_if(excluded.begin(), excluded.end(), [](uint8_t e) { return e != 0; });
  return std::min(1.0, params_.camera_check.keyframe_pull_gain * double(n) / double(excluded.size()));
}

// The frame's depth without the pixels of this frame's excluded classes (people).
std::vector<float> CoFusion::depth_outside_excluded(const float* depth_m) const {
  const size_t n = size_t(intrinsics_.width) * size_t(intrinsics_.height);
  if (!frame_excluded_ || frame_excluded_->size() != n) return std::vector<float>(depth_m, depth_m + n);
  return depth_where(depth_m, n, [&](size_t i) { return !(*frame_excluded_)[i]; });
}

// keyframe_camera_pose: the CPU job's, where process() started one.
std::optional<KeyframePose> CoFusion::frame_keyframe_pose(const float* depth_m) const {
  return frame_keyframe_pose_ ? frame_keyframe_pose_() : keyframe_camera_pose(depth_m);
}

// The camera's pose from this frame's ORB features outside the excluded pixels, matched against
// the keyframes' together (KeyframeDatabase::pnp_pose); nullopt without keyframes or a match.
std::optional<KeyframePose> CoFusion::keyframe_camera_pose(const float* depth_m) const {
  if (!frame_rgb_ || keyframes_.size() == 0) return std::nullopt;
  const std::vector<float> depth = depth_outside_excluded(depth_m);
  const FrameEncoding encoding = keyframes_.encode(frame_rgb_, depth.data(), intrinsics_.width, intrinsics_.height);
  return keyframes_.pnp_pose(encoding, keyframes_.features(frame_rgb_, depth.data(), intrinsics_), intrinsics_);
}

// CameraCheckParams::agreeing_frames: whether the refused tracked pose and the one refused in the
// frame before (both against the model) are a motion that fits the previous frame's depth, for
// the agreeing_frames-th frame in a row: then the replaced poses were the ones off (a wrong
// velocity carried, a jump that was not one), and the model's pose is taken back.
bool CoFusion::tracked_poses_agree(const Model& bg, const float* depth_m, const CameraFits& f) {
  const CameraCheckParams& p = params_.camera_check;
  const Eigen::Isometry3d tracked_world = T_world_camera_ * bg.motion;
  if (refused_T_world_tracked_) {
    const Eigen::Isometry3d between = refused_T_world_tracked_->inverse() * tracked_world;
    const bool agree = depth_fit(depth_m, previous_depth_m_.data(), intrinsics_, between, p) >= p.min_fit_ratio * f.start;
    agreeing_refusals_ = agree ? agreeing_refusals_ + 1 : 0;
  }
  refused_T_world_tracked_ = tracked_world;
  return p.agreeing_frames > 0 && agreeing_refusals_ >= p.agreeing_frames;
}

// The camera's pose after this frame's motion (the background's).
Eigen::Isometry3d CoFusion::camera_pose_after(const Eigen::Isometry3d& camera_motion) const {
  return orthonormalised(T_world_camera_ * camera_motion);
}

// Poses: the background's motion is the camera's; every other model's follows from its own.
void CoFusion::update_poses(const std::vector<Model*>& active, CoFusionFrame& out) {
  const Model& bg = *active.front();
  const Eigen::Isometry3d T_world_camera_prev = T_world_camera_;
  if (frame_ > 0) {
    T_world_camera_ = camera_pose_after(bg.motion);
    out.camera_tracking = bg.tracking;
    for (Model* m : active)
      if (m->id != 0)
        m->surfels.T_world_model = orthonormalised(T_world_camera_ * m->motion.inverse() * T_world_camera_prev.inverse() *
                                                   m->surfels.T_world_model);
  }
  out.T_world_camera = T_world_camera_;
}

// CameraRetrackParams: whether this frame's segmentation took a surge of the pixels the camera
// tracked with (`tracked_slots`) away from the background; keeps the baseline.
bool CoFusion::retrack_surge(const std::vector<uint8_t>& tracked_slots, int background_slot, uint32_t resting) {
  const CameraRetrackParams& p = params_.retrack;
  const size_t n = slots_.size();
  // A resting model's pixels are still the background's to track with.
  const auto tracks = [&](uint8_t slot) { return slot == background_slot || (slot < 32 && (resting >> slot & 1u)); };
  std::vector<uint8_t> taken(n, 0);
  for (size_t i = 0; i < n; ++i) taken[i] = tracked_slots[i] == background_slot && !tracks(slots_[i]);
  segmentation::label_components(taken.data(), intrinsics_.width, intrinsics_.height, std::optional<uint8_t>{0},
                                 retrack_components_);
  double taken_pixels = 0;
  for (const auto& c : retrack_components_.components)
    if (double(c.pixels) >= p.min_region_fraction * double(n)) taken_pixels += double(c.pixels);
  const double share = taken_pixels / double(n);
  std::vector<double> before(retrack_taken_.begin(), retrack_taken_.end());
  retrack_taken_.push_back(share);
  if (int(retrack_taken_.size()) > p.baseline_frames) retrack_taken_.pop_front();
  double baseline = 0;
  if (!before.empty()) {
    std::nth_element(before.begin(), before.begin() + before.size() / 2, before.end());
    baseline = before[before.size() / 2];
  }
  return share >= p.min_taken_fraction && share >= p.surge_factor * baseline;
}

// SemanticParams::track_woken: each of `were_resting` that this frame's lifecycle woke (it has
// moved since it rested) is tracked at once with its pixels of this frame, from where it rested;
// its pose in this frame, and the surfels it fuses now, then follow the motion it made while it
// was still held at rest (else both wait for the next frame).
void CoFusion::track_woken(const std::vector<Model*>& were_resting, CoFusionFrame& out) {
  std::vector<Model*> woken;
  for (Model* m : were_resting)
    if (!m->resting && m->state == ModelState::kActive && m->slot >= 0 && m->slot < kSlots) woken.push_back(m);
  if (woken.empty() || !params_.semantic.track_woken || camera_history_.empty() || !camera_history_.back()) return;
  main_stream_.wait(labels_uploaded_);
  const std::vector<PixelRect> rects = slot_rects(slots_, intrinsics_.width, intrinsics_.height);
  std::vector<TrackingJob> jobs;
  for (Model* m : woken) {
    m->track_rect = rects[size_t(m->slot)];
    gpu::CommandList c = m->stream.begin();
    motion_.mask_levels(c, live_.levels, m->masked, labels_, 1u << m->slot, m->track_rect);
    m->stream.wait(m->stream.submit(std::move(c)));
    choose_object_terms(*m);
    jobs.push_back(tracking_job(*m, m->motion));
  }
  track_together(main_stream_, jobs);
  // Its prediction was made at its rest pose from the previous frame's camera.
  const Eigen::Isometry3d T_world_previous = *camera_history_.back();
  for (size_t k = 0; k < woken.size(); ++k) {
    Model& m = *woken[k];
    const TrackingResult& r = jobs[k].result;
    if (r.failed) continue;
    const Eigen::Isometry3d T_previous_model = T_world_previous.inverse() * m.surfels.T_world_model;
    const Eigen::Isometry3d T_world_model = orthonormalised(T_world_camera_ * r.T_reference_live.inverse() * T_previous_model);
    const double moved_mm = 1000.0 * (T_world_model.translation() - m.surfels.T_world_model.translation()).norm();
    m.surfels.T_world_model = T_world_model;
    m.motion = m.last_motion = m.T_prediction_live = r.T_reference_live;
    m.tracking = r;
    out.events.push_back("frame " + std::to_string(frame_) + ": model " + std::to_string(m.id) + " tracked from its rest (" +
                         std::to_string(int(std::lround(moved_mm))) + " mm)");
  }
}

// CameraRetrackParams: the background tracked again from its tracked motion with this frame's
// labels (uploaded by the lifecycle); the camera and every moving model's world pose (their poses
// in the camera stay) move by the correction.
void CoFusion::retrack_camera(const std::vector<uint8_t>& tracked_slots, CoFusionFrame& out) {
  const std::vector<Model*> live = live_models();
  Model& bg = *live.front();
  if (params_.retrack.min_taken_fraction <= 0 || tracked_slots.size() != slots_.size()) return;
  // While the camera moves fast, what leaves the background is blur and new surfaces, not movers
  // (the spawns' rule, LifecycleParams::spawn_max_camera_*), and the camera needs those pixels.
  const uint32_t resting = resting_slots(live);  // this frame's (the segmentation may have spawned some)
  if (!retrack_surge(tracked_slots, bg.slot, resting) || !spawn_camera_steady(bg)) return;
  main_stream_.wait(labels_uploaded_);
  gpu::CommandList c = bg.stream.begin();
  motion_.mask_levels(c, live_.levels, bg.masked, labels_, tracked_slot_mask(bg, resting), bg.track_rect);
  bg.stream.wait(bg.stream.submit(std::move(c)));
  std::vector<TrackingJob> job{tracking_job(bg, bg.motion)};
  track_together(main_stream_, job);
  const TrackingResult& result = job.front().result;
  if (result.failed) return;
  const Eigen::Isometry3d T_world_previous = T_world_camera_ * bg.motion.inverse();
  const Eigen::Isometry3d T_world_camera = orthonormalised(T_world_previous * result.T_reference_live);
  const Eigen::Isometry3d correction = T_world_camera * T_world_camera_.inverse();
  if (correction.translation().norm() > params_.retrack.max_correction_m ||
      rotation_deg(correction) > params_.retrack.max_correction_deg)
    return;
  for (Model* m : live)
    if (m->id != 0 && !m->resting) m->surfels.T_world_model = orthonormalised(correction * m->surfels.T_world_model);
  T_world_camera_ = T_world_camera;
  bg.motion = bg.last_motion = bg.T_prediction_live = result.T_reference_live;
  bg.tracking = result;
  out.T_world_camera = T_world_camera_;
  out.camera_tracking = bg.tracking;
  out.camera_retracked = true;
}

// Motion segmentation over the models' costs, then the lifecycle; excluded pixels are no model's
// and no outlier region's (they spawn nothing) and end as mover pixels.
void CoFusion::segment(const segmentation::Superpixels& superpixels, const float* depth_m, const uint8_t* rgb,
                       const std::vector<uint8_t>& excluded, std::vector<Model*>& active, CoFusionFrame& out,
                       std::vector<int>& spawned_slots) {
  auto lap = Clock::now();
  const auto part = [&](const char* name) {
    const auto now = Clock::now();
    out.segment_parts_ms.emplace_back(name, ms_between(lap, now));
    lap = now;
  };
  std::vector<std::vector<float>> costs(active.size());
  tbb::parallel_for(size_t{0}, active.size(), [&](size_t k) { model_costs(*active[k], depth_m, costs[k]); });
  part("costs");
  std::vector<std::span<const float>> views(costs.begin(), costs.end());
  segmentation::SegmentationResult seg = segmenter_.segment(superpixels, rgb, depth_m, views);
  mark_excluded(excluded, segmentation::kNoLabel, seg.labels);
  out.crf_nodes_ms = seg.prepare_ms;
  out.segment_parts_ms.emplace_back("unaries", seg.unary_ms);
  out.segment_parts_ms.emplace_back("CRF", seg.crf_ms);
  out.segment_parts_ms.emplace_back("components", seg.post_ms);
  lap = Clock::now();
  // Two independent pieces of evidence for spawns, side by side.
  tbb::parallel_invoke(
      [&] { rising_ = rising_background(superpixels, costs.front(), seg.labels, static_cast<uint8_t>(active.size())); },
      [&] { changed_ = changed_since_previous(superpixels, depth_m, rgb, seg.labels); });
  part("rising cost and previous frame");
  slots_ = apply_lifecycle(seg, costs, depth_m, rgb, active, out, spawned_slots);
  if (mark_excluded(excluded, kMoverSlot, slots_)) upload_labels(slots_);
  part("lifecycle");
}

// Without motion segmentation (or on the first frame) everything with depth belongs to the
// background. The GPU needs the labels only to mask the next frame's tracking, which a
// background-only run does not do.
void CoFusion::label_all_background(const float* depth_m, const std::vector<uint8_t>& excluded) {
  for (size_t i = 0; i < slots_.size(); ++i) slots_[i] = depth_m[i] > 0.0f ? 0 : kNoSlot;
  unexplained_slots_.clear();
  mark_excluded(excluded, kMoverSlot, slots_);
  if (params_.motion_segmentation) upload_labels(slots_);
  live_models().front()->pixels = static_cast<int>(std::count(slots_.begin(), slots_.end(), uint8_t{0}));
}

// Fusion, one task per active model (a new one included). A new model's geometry may already be
// in other models: the background (an object that started moving after it was fused) or an object
// it moved with until now (an arm that carried the cube and lets go). Each older model drops its
// surfels on the new region's pixels.
void CoFusion::fuse_models(const std::vector<int>& spawned_slots) {
  const std::vector<Model*> fusing = live_models();
  const std::vector<PixelRect> fuse_rects = slot_rects(slots_, intrinsics_.width, intrinsics_.height);
  // The background fuses the pixels of resting models too (as they are after this frame's
  // lifecycle): it keeps their surfels to track with.
  const uint32_t resting = resting_slots(fusing);
  for_each_model(fusing, [&](Model& m) {
    const bool is_new = std::find(spawned_slots.begin(), spawned_slots.end(), m.slot) != spawned_slots.end();
    fuse_model(m, is_new ? std::vector<int>{} : spawned_slots, fuse_rects[size_t(m.slot)], m.id == 0 ? resting : 0u);
  });
}

// What this frame leaves that needs no fused model (so it runs beside the fusion): the output
// labels (with `superpixels`, pixels without depth take their superpixel's model), the keyframes,
// and the previous frame's depth and grey levels for the next frame.
void CoFusion::keep_frame(CameraState camera, const FrameEncoding& encoding, const float* depth_m, const uint8_t* rgb,
                          const segmentation::Superpixels* superpixels, const std::vector<uint8_t>& excluded,
                          CoFusionFrame& out) {
  std::vector<uint16_t> slot_to_id(kSlots, 0xFFFF);
  for (const Model* m : live_models()) slot_to_id[m->slot] = static_cast<uint16_t>(m->id);
  const size_t n = slots_.size();
  out.labels.assign(n, 0xFFFF);
  // A pixel the segmentation gave to a model that does not explain it is still that model's.
  const bool unexplained = unexplained_slots_.size() == n;
  if (camera != CameraState::kLost)
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i < r.end(); ++i) {
        const uint8_t slot = unexplained && slots_[i] == kNoSlot ? unexplained_slots_[i] : slots_[i];
        out.labels[i] = slot < kMoverSlot ? slot_to_id[slot] : uint16_t{0xFFFF};
      }
    });
  if (superpixels) segmentation::label_depthless_pixels(out.labels, *superpixels, depth_m, uint16_t{0xFFFF}, excluded);
  // A keyframe's features are stored as world points, so only what stands still gives them: the
  // background's pixels and those of resting models. A person or a moving object would be matched
  // where it no longer is.
  if (camera == CameraState::kTracking) {
    std::array<bool, kSlots> still{};
    for (const auto& m : models_)
      if (m->slot >= 0 && m->slot < kSlots && (m->id == 0 || m->resting)) still[size_t(m->slot)] = true;
    const auto still_features = [&] {
      const std::vector<float> depth =
          depth_where(depth_m, slots_.size(), [&](size_t i) { return slots_[i] < kSlots && still[slots_[i]]; });
      return keyframes_.features(rgb, depth.data(), intrinsics_);
    };
    keyframes_.add_if_novel(encoding, still_features, T_world_camera_);
  }
  if (params_.camera_check.enabled || params_.lifecycle.spawn_rigidity.enabled) {
    previous_depth_m_.assign(depth_m, depth_m + n);
  }
  if (params_.motion_segmentation && params_.lifecycle.slide_min_shift_px > 0 && rgb) {  // LifecycleParams::slide_*
    previous_intensity_.resize(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i < r.end(); ++i) previous_intensity_[i] = grey_level(rgb, i);
    });
  }
}

// Bookkeeping and the report after fusion: trajectories, model statuses, the recent tracking
// quality that relocalisation is judged by, the camera's history.
void CoFusion::finish_frame(CameraState camera, CoFusionFrame& out) {
  for (auto& m : models_) report_cull(*m, out);
  for (Model* m : live_models()) {
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
  const Model& bg = *models_.front();
  if (camera == CameraState::kTracking && frame_ > 0) {
    recent_tracking_.emplace_back(bg.tracking.inlier_ratio, bg.tracking.icp_rms_m);
    if (int(recent_tracking_.size()) > params_.relocalisation.recent_frames) recent_tracking_.erase(recent_tracking_.begin());
  }
  camera_history_.push_back(camera == CameraState::kLost ? std::nullopt : std::optional(T_world_camera_));
  if (camera_history_.size() > kCameraHistoryFrames) camera_history_.pop_front();
  ++frame_;
  semantic_ = nullptr;  // the caller's, valid during process() only
  frame_rgb_ = nullptr, frame_excluded_ = nullptr, frame_keyframe_pose_ = nullptr, frame_pull_gain_ = 0;
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
