#pragma once
// Parameters, result and the host side of frame-to-model tracking: the Gauss-Newton loop over
// the per-iteration sums, shared by the GPU tracker (tracker.h) and its CPU reference
// (tracker_reference.h) so both run exactly the same solver, checks and failure rules.
#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "common/se3.h"

namespace cofusion::slam {

// Every threshold of tracking. Units in the names; defaults after ElasticFusion where it has
// one, else measured on the synthetic scenes and TUM fr2/desk (see tests/slam/tracker_test.cpp).
struct TrackerParams {
  // Most Gauss-Newton iterations per pyramid level, index 0 = full resolution. Each level has 1/4
  // of the pixels of the one below, so coarse iterations are cheap and do most of the work: on
  // lavapipe one 640x480 iteration (ICP + photometric) costs about 14 ms of GPU time, 320x240 3 ms,
  // 80x60 0.5 ms. The finest level gets one iteration (its step is below a millimetre once the
  // coarser ones converged); the coarser ones enough to converge where the view is far and weakly
  // constrained (docs/experiments.md, "Bonn crowd: the empty office").
  std::vector<int> iterations_per_level = {1, 4, 6, 10};

  // ICP data association (ElasticFusion's values): projective nearest pixel, then rejection.
  double max_correspondence_distance_m = 0.1;  // |T v_live - v_ref| above this: no correspondence
  double max_normal_angle_deg = 20.0;          // angle(R n_live, n_ref) above this: no correspondence

  // Photometric term. Residuals are in intensity / 255 (so in [-1, 1]), ICP residuals in metres;
  // the combined system is H = H_icp + lambda * H_rgb. lambda = (sigma_icp / sigma_rgb)^2 weighs
  // each term by its inverse noise variance: about 3 mm of depth noise against about 2.5/255 of
  // intensity noise gives 0.1.
  bool use_photometric = true;
  // Measured on the TUM recordings with whole-sequence tracking (cofusion run): 1.0 halves the
  // fast-rotation fr1/rpy error of 0.1 (2.5 vs 4.4 cm ATE over 100 frames) and keeps fr2/desk.
  double photometric_weight = 1.0;  // the paper's lambda
  // Photometric Jacobian from the mean of the reference's gradient (at the warped point) and the
  // live frame's (at the pixel) instead of the reference's alone: efficient second-order
  // minimisation (Benhimane & Malis 2004), which approximates the true Hessian's curvature. The
  // model's predicted image is blurred by fusion, the live one is sharp. TUM fr2/desk 6.35 -> 6.1
  // mm, fr1/rpy 2.78 -> 2.68 cm (before the TUM depth correction). Needs the live frame's
  // gradients (the pipelines compute them: SlamParams::effective_preprocess).
  bool esm_gradient = true;
  // Also compare every predicted model pixel with the (unmasked) live intensity where the motion
  // puts it (model -> live; the live gradient for its Jacobian), in the photometric sums. A model is
  // tracked with the live pixels of its previous label, so its outline never meets the background
  // there; from the model's side it does. An object whose pixels only constrain some directions
  // (one striped face sliding along its stripes) is held by its outline in the others. The live
  // frame's gradients are needed (as for esm_gradient). CoFusion turns it on for object models
  // (LifecycleParams::object_outline_photometric). The prediction's rim (model pixels with a
  // 4-neighbour the model does not cover) is left out: splatted discs overhang the silhouette, so
  // the rim shows the object's colour where the live image shows what lies beside it, and it held
  // moving objects back (docs/experiments.md).
  bool outline_photometric = false;
  // The live -> model photometric term leaves out live pixels whose nearest reference pixel lies
  // on the prediction's rim (as the outline term always does): splatted discs overhang the
  // silhouette, so the rim's fused colours mix the object's with what lay beside it. CoFusion turns
  // it on for object models (LifecycleParams::object_photometric_skip_rim).
  bool photometric_skip_rim = false;
  // The outline term's robust scale relative to the live -> model term's (photometric_huber_k or
  // photometric_cauchy_k times the RMS residual, times this; 0 = not robust). Its informative
  // residuals are the large ones at the silhouette, where the model's outline meets the
  // background, which the robust weight caps.
  double outline_huber_scale = 1.0;
  // Outline term: a model pixel where the live depth is nearer than the model point by more than
  // this is occluded (another object in front) and left out.
  double outline_occlusion_margin_m = 0.03;
  // Whether the photometric Jacobian reads the live frame's gradients (ESM or the outline term).
  bool needs_live_gradients() const { return use_photometric && (esm_gradient || outline_photometric); }
  // |I_ref - I_live| / 255 above this is an outlier (occlusion, specularity, wrong association).
  double max_intensity_diff = 0.3;
  // Robust photometric term: residuals beyond photometric_huber_k times the RMS photometric
  // residual of the previous iteration get Huber weight delta / |r| (the first iteration of a
  // call is plain least squares; 0 = never robust). A scale that follows the residuals keeps the
  // wide basin while they are large (fast rotation) and stops a small high-contrast moving object
  // from dragging the camera once the static scene has converged: on the one_object scene the
  // camera followed a sliding checker box by 1 cm per frame (7 cm error) with plain least squares,
  // 6 mm at most with 1.345 (the textbook 95%-efficiency constant); TUM fr2/desk 6.4 vs 7.3 mm,
  // fr1/rpy 2.9 vs 3.0 cm. A fixed delta, or robust weights only at the finer levels, lost either
  // fr1/rpy (4-20 cm) or the box.
  double photometric_huber_k = 1.345;
  // A redescending photometric loss instead: with k > 0, Cauchy's weight 1 / (1 + (r / delta)^2),
  // delta = this times the previous iteration's RMS photometric residual (2.385: 95 % efficiency
  // for Gaussian noise), whose pull falls off for large residuals where Huber's stays constant.
  // 0 = Huber's, by photometric_huber_k. Off by default: it keeps a slowly starting checker box
  // from dragging the camera (docs/validation/crossing.json) and TUM fr1/rpy gains, but Bonn crowd
  // loses and spawns a model from its static office (docs/experiments.md, "A redescending (Cauchy)
  // photometric loss").
  double photometric_cauchy_k = 0;
  // The scale factor of the photometric term's robust weight (Cauchy's or Huber's).
  double photometric_robust_k() const { return photometric_cauchy_k > 0 ? photometric_cauchy_k : photometric_huber_k; }
  // Whether photometric residuals need the reweighted reduction kernel (Cauchy, gradient or tile
  // weights).
  bool photometric_reweighted() const {
    return photometric_gradient_c > 0 || photometric_cauchy_k > 0 || photometric_tile_weights;
  }
  // Robust ICP term, by the same rule: point-to-plane residuals beyond icp_huber_k times the
  // previous iteration's RMS ICP residual get Huber weight delta / |r| (0 = never robust). Points
  // of something that moves a little (a person close to the camera), inside the correspondence
  // distance, then pull the pose less than the static scene does.
  double icp_huber_k = 0;
  // Depth-noise weighting of the ICP term: the residual (and Jacobian) of a live point deeper than
  // this is scaled by sigma(this depth) / sigma(its depth), sigma the sensor's axial noise
  // (shared/depth_noise.h: 2 mm at 1 m, 14 mm at 3 m), so every pair counts by how much its depth
  // can be trusted; nearer points keep weight 1. Far, noisy depth otherwise outweighs the
  // photometric term and the near geometry (an office seen from 2-5 m). 0 = no weighting. Off by
  // default: 1 m took Bonn crowd from 12.8-15 to 6.9 cm but the generated walking_people scene
  // from 3.6 mm to 3.1 cm (docs/experiments.md); `--config` turns it on.
  double icp_noise_reference_depth_m = 0;
  // Gradient-dependent photometric weights (as DSO's): a residual counts by c^2 / (c^2 + |g|^2),
  // g the intensity gradient there (intensity / 255 per pixel) and c this; 0 = every residual by
  // its robust weight alone.
  double photometric_gradient_c = 0;
  // Photometric residuals of live pixels count by their tile's weight (ICP_RGB_TILES_X x
  // ICP_RGB_TILES_Y tiles of each level), as Tracker::set_photometric_tile_weights last set them
  // (1 until then): the camera's, by CameraCheckParams::photometric_tile_cap.
  bool photometric_tile_weights = false;
  // Exposure compensation: the live intensity is multiplied by a gain, re-estimated at every
  // iteration as sum(I_reference) / sum(I_live) over the photometric term's pixels, before the
  // photometric residuals are formed. Auto-exposure changes a frame's brightness by 20% within a
  // few frames (Bonn crowd frames 18-24) while the model keeps the colours it fused; without the
  // gain that difference pulls the pose by centimetres. The gain is clamped to
  // [1 / max_exposure_gain, max_exposure_gain].
  bool exposure_compensation = true;
  double max_exposure_gain = 2.0;

  // Failure rules. On failure the result pose is the guess.
  // Fewest ICP correspondences at full resolution; coarser levels need this times their share of
  // the full-resolution pixels (at least 12).
  int min_correspondences = 1000;
  // A coarser level with fewer ICP correspondences than this is skipped (tracking goes on at the
  // next finer level from the pose so far) instead of solved: a small object covers a few dozen
  // pixels at 80x60, too few for a stable step (on one_object a 23 cm step from 66 pixels made the
  // box's model lose the box when it was lifted). The finest level still fails below
  // min_correspondences.
  int min_coarse_level_correspondences = 300;
  // Final TrackingResult::inlier_ratio (at the finest level run): ICP inliers / live pixels with a
  // valid vertex and normal that do not occlude the reference. For object models, whose
  // predicted view covers part of the image, the caller lowers this.
  double min_inlier_ratio = 0.1;
  // The system is degenerate when, after balancing its rotation block against its translation
  // block (rotation rescaled by the point cloud's effective radius), its smallest eigenvalue is
  // below this fraction of its largest (e.g. a single plane without texture: motion along it is
  // unobservable).
  double min_eigenvalue_ratio = 1e-5;
  // A single Gauss-Newton step larger than this is divergence, not convergence.
  double max_step_translation_m = 0.2;
  double max_step_rotation_deg = 20.0;
  // The estimate may move at most this far from the guess over the whole call.
  double max_translation_from_guess_m = 0.5;
  double max_rotation_from_guess_deg = 45.0;

  // A level stops early once a step moves less than both of these (0.1 mm, 0.006 degrees).
  double converged_translation_m = 1e-4;
  double converged_rotation_rad = 1e-4;

  // GPU only: workgroups of the reduction (each loops over its share of the pixels); 0 = by
  // device. On a device that is the CPU itself, one per thread it runs them on
  // (gpu::Context::software_threads, at most kCpuReductionWorkgroups): lavapipe pays about 0.04
  // ms per workgroup beyond its threads' share of the pixels, so 16 took an 80x60 level 0.8 ms
  // where 2 take 0.23 (docs/experiments.md). A GPU wants more to spread over its
  // multiprocessors, but not so many that adding their partial sums on the host outweighs it
  // (kGpuReductionWorkgroups).
  int reduction_workgroups = 0;
  static constexpr int kCpuReductionWorkgroups = 16;
  static constexpr int kGpuReductionWorkgroups = 64;
};

// What one iteration's sums depend on besides the pose. Huber thresholds: residuals beyond them
// get weight delta / |r| (the sums then hold w J^T J, w J^T r, w r^2); 0 = plain least squares
// for that term.
struct IterationScales {
  double icp_m = 0;  // point-to-plane residual, metres
  double rgb = 0;    // photometric residual, intensity / 255
  // The live intensity is multiplied by this before it is compared with the reference's: the
  // live frame's exposure relative to the model's colours (TrackerParams::exposure_compensation).
  double live_gain = 1;
};

struct TrackingResult {
  Eigen::Isometry3d T_reference_live = Eigen::Isometry3d::Identity();  // the guess when failed
  // Statistics of the last iteration (finest level run), measured at the pose before its update
  // (that update is below the convergence thresholds when the level converged).
  int icp_inliers = 0;        // ICP correspondences
  int rgb_residuals = 0;      // photometric residuals (0 without the term)
  int valid_live_pixels = 0;  // live pixels with a valid vertex and normal
  // Of those, the ones in front of the reference surface by more than the correspondence distance
  // (people walking in front of the background): they cannot correspond to the reference from any
  // pose near this one, and they contradict none.
  int occluding_live_pixels = 0;
  // icp_inliers / (valid_live_pixels - occluding_live_pixels): of the live pixels that could meet
  // the reference, the share that does. A view mostly covered by movers keeps a high ratio when
  // what it sees of the reference is aligned.
  double inlier_ratio = 0;
  double icp_rms_m = 0;       // RMS point-to-plane residual, metres
  double rgb_rms = 0;         // RMS photometric residual (Huber-weighted), intensity / 255
  double live_intensity_gain = 1;  // the live frame's exposure gain used by the last iteration
  double eigenvalue_ratio = 0;  // balanced smallest / largest eigenvalue of the last system
  int iterations = 0;         // Gauss-Newton iterations run over all levels
  int skipped_diverging_levels = 0;  // coarse levels whose step diverged and whose steps were undone
  bool failed = false;
  std::string failure_reason;  // one line; empty unless failed
};

// The sums one iteration needs, in double. Each term: J^T J upper triangle (21, row-major), J^T r
// (6), sum r^2, number of residuals (see shaders/shared/host_device.h).
struct LinearSystemSums {
  static constexpr int kTermValues = 29;
  std::array<double, kTermValues> icp{};
  std::array<double, kTermValues> rgb{};
  double valid_live_pixels = 0;  // live pixels with a valid vertex and normal
  // Of those, the ones in front of the reference surface by more than the correspondence distance:
  // occluders in the reference's free space (host_device.h, ICP_RGB_OFFSET_OCCLUDING).
  double occluding_live_pixels = 0;
  // Over the direct photometric term's geometrically valid pixels (before its intensity outlier
  // test): the sums of the reference's intensity and of the live intensity (without gain), [0, 255].
  double reference_intensity_sum = 0;
  double live_intensity_sum = 0;
};

// The robust scales of the iteration after one whose residual statistics `result` holds (Huber's
// or Cauchy's scale is its factor times that iteration's RMS), with the live frame at `live_gain`.
IterationScales next_iteration_scales(const TrackerParams& params, const TrackingResult& result, double live_gain);

// Unpacks one term into H = J^T J, b = J^T r.
void unpack_term(const std::array<double, LinearSystemSums::kTermValues>& term, Matrix6d& H, Vector6d& b);

// The live frame's exposure gain that one iteration's sums measure, sum(I_reference) /
// sum(I_live) clamped by TrackerParams::max_exposure_gain; `current` when they hold no pixel, 1
// without exposure compensation.
double exposure_gain(const LinearSystemSums& sums, const TrackerParams& params, double current);

// Smallest / largest eigenvalue of H after scaling the rotation rows/columns so both diagonal
// blocks have equal trace (0 when H has no translation information).
double balanced_eigenvalue_ratio(const Matrix6d& H);

// The sums of one iteration at pyramid level `level` (0 = finest) and pose T_reference_live, with
// residuals beyond the scales Huber-weighted.
using SumsAtLevel =
    std::function<LinearSystemSums(int level, const Eigen::Isometry3d& T_reference_live, const IterationScales& huber)>;

// Coarse-to-fine Gauss-Newton over `level_pixels.size()` levels (pixel counts, finest first):
// T <- exp(xi) * T with H xi = -b, H = H_icp + lambda H_rgb. Applies every failure rule of
// `params`; on failure returns the guess.
TrackingResult gauss_newton(const std::vector<long>& level_pixels, const SumsAtLevel& sums,
                            const Eigen::Isometry3d& T_reference_live_guess, const TrackerParams& params);

// The same Gauss-Newton loop, turned inside out so that the caller computes the sums: while
// request() names a level, pose and scales, the caller forms those sums and hands them to take().
// Several models' trackings then advance in lockstep, one GPU submission per iteration for all of
// them (track_together). gauss_newton() is this loop with a callback.
class GaussNewton {
 public:
  struct Request {
    int level = 0;
    Eigen::Isometry3d T_reference_live = Eigen::Isometry3d::Identity();
    IterationScales scales;
  };
  // `level_pixels` and `params` must outlive this object.
  GaussNewton(const std::vector<long>& level_pixels, const Eigen::Isometry3d& T_reference_live_guess,
              const TrackerParams& params);
  // The sums the loop needs next; none once it has finished.
  const std::optional<Request>& request() const { return request_; }
  // The sums of request(); advances the loop. Only while request() has a value.
  void take(const LinearSystemSums& sums);
  bool done() const { return !request_; }
  // The outcome; only once done().
  const TrackingResult& result() const { return result_; }

 private:
  void start_level(int level);
  void iterate(const LinearSystemSums& s);
  void fail(const std::string& reason);
  void finish();

  const std::vector<long>& level_pixels_;
  const TrackerParams& params_;
  Eigen::Isometry3d guess_;
  Eigen::Isometry3d T_;
  Eigen::Isometry3d T_level_start_;
  int level_ = 0;
  int iteration_ = 0;  // within the level
  double min_correspondences_ = 0;  // at this level
  bool evaluated_ = false;  // the first sums were taken (and the exposure re-measured)
  IterationScales scales_;  // the first iteration is plain least squares
  std::optional<Request> request_;
  TrackingResult result_;
};

// Throws cofusion::Error naming `what` when a parameter is out of range.
void validate(const TrackerParams& params, const std::string& what);

}  // namespace cofusion::slam
