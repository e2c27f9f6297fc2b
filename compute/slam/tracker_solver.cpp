#include "slam/tracker_solver.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "common/error.h"

namespace cofusion::slam {
namespace {
constexpr double kRadPerDeg = std::numbers::pi / 180.0;

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}
}  // namespace

void unpack_term(const std::array<double, LinearSystemSums::kTermValues>& term, Matrix6d& H, Vector6d& b) {
  int k = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) H(i, j) = H(j, i) = term[k++];
  for (int i = 0; i < 6; ++i) b(i) = term[21 + i];
}

double exposure_gain(const LinearSystemSums& s, const TrackerParams& params, double current) {
  if (!params.exposure_compensation || !params.use_photometric) return 1.0;
  if (!(s.reference_intensity_sum > 0 && s.live_intensity_sum > 0)) return current;
  return std::clamp(s.reference_intensity_sum / s.live_intensity_sum, 1.0 / params.max_exposure_gain,
                    params.max_exposure_gain);
}

double balanced_eigenvalue_ratio(const Matrix6d& H) {
  const double trace_t = H.topLeftCorner<3, 3>().trace(), trace_r = H.bottomRightCorner<3, 3>().trace();
  if (!(trace_t > 0) || !(trace_r > 0)) return 0;
  // Rotation by w moves a point at distance d by about d*w: rescaling w by d (the effective
  // radius, from the two traces) puts both blocks in metres of point motion.
  const double d = std::sqrt(trace_r / trace_t);
  Vector6d s;
  s << 1, 1, 1, 1 / d, 1 / d, 1 / d;
  const Matrix6d Hs = s.asDiagonal() * H * s.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(Hs, Eigen::EigenvaluesOnly);
  const auto& ev = eig.eigenvalues();  // ascending
  if (!(ev(5) > 0)) return 0;
  return std::max(0.0, ev(0)) / ev(5);
}

void validate(const TrackerParams& p, const std::string& what) {
  auto bad = [&](const std::string& why) { throw Error(what + ": invalid tracker parameter: " + why); };
  if (p.iterations_per_level.empty()) bad("iterations_per_level is empty");
  for (int n : p.iterations_per_level)
    if (n < 0) bad("iterations_per_level has a negative entry");
  if (!(p.max_correspondence_distance_m > 0)) bad("max_correspondence_distance_m must be > 0");
  if (!(p.max_normal_angle_deg > 0 && p.max_normal_angle_deg <= 180)) bad("max_normal_angle_deg must be in (0, 180]");
  if (!(p.photometric_weight >= 0 && std::isfinite(p.photometric_weight))) bad("photometric_weight must be >= 0");
  if (!(p.max_intensity_diff > 0)) bad("max_intensity_diff must be > 0");
  if (!(p.photometric_huber_k >= 0)) bad("photometric_huber_k must be >= 0");
  if (!(p.icp_huber_k >= 0)) bad("icp_huber_k must be >= 0");
  if (!(p.outline_huber_scale >= 0)) bad("outline_huber_scale must be >= 0");
  if (!(p.max_exposure_gain >= 1 && std::isfinite(p.max_exposure_gain))) bad("max_exposure_gain must be >= 1");
  if (!(p.photometric_cauchy_k >= 0 && std::isfinite(p.photometric_cauchy_k))) bad("photometric_cauchy_k must be >= 0");
  if (!(p.photometric_gradient_c >= 0 && std::isfinite(p.photometric_gradient_c))) bad("photometric_gradient_c must be >= 0");
  if (!(p.icp_noise_reference_depth_m >= 0 && std::isfinite(p.icp_noise_reference_depth_m)))
    bad("icp_noise_reference_depth_m must be >= 0");
  if (!(p.outline_occlusion_margin_m >= 0 && std::isfinite(p.outline_occlusion_margin_m)))
    bad("outline_occlusion_margin_m must be >= 0");
  if (p.min_correspondences < 0) bad("min_correspondences must be >= 0");
  if (p.min_coarse_level_correspondences < 0) bad("min_coarse_level_correspondences must be >= 0");
  if (!(p.min_inlier_ratio >= 0 && p.min_inlier_ratio <= 1)) bad("min_inlier_ratio must be in [0, 1]");
  if (!(p.min_eigenvalue_ratio >= 0 && p.min_eigenvalue_ratio < 1)) bad("min_eigenvalue_ratio must be in [0, 1)");
  if (!(p.max_step_translation_m > 0) || !(p.max_step_rotation_deg > 0)) bad("max step sizes must be > 0");
  if (!(p.max_translation_from_guess_m > 0) || !(p.max_rotation_from_guess_deg > 0))
    bad("max motion from the guess must be > 0");
  if (!(p.converged_translation_m >= 0) || !(p.converged_rotation_rad >= 0)) bad("convergence thresholds must be >= 0");
  if (p.reduction_workgroups < 0) bad("reduction_workgroups must be >= 0 (0: by device)");
}

IterationScales next_iteration_scales(const TrackerParams& params, const TrackingResult& result, double live_gain) {
  return {params.icp_huber_k * result.icp_rms_m, params.photometric_robust_k() * result.rgb_rms, live_gain};
}

namespace {
// The iteration's figures from its sums (correspondences, inlier ratio, RMS residuals) and the
// robust scales and exposure gain of the next iteration.
void take_statistics(const LinearSystemSums& s, const TrackerParams& params, TrackingResult& result,
                     IterationScales& scales) {
  ++result.iterations;
  result.icp_inliers = static_cast<int>(s.icp[28]);
  result.rgb_residuals = static_cast<int>(s.rgb[28]);
  result.valid_live_pixels = static_cast<int>(s.valid_live_pixels);
  result.occluding_live_pixels = static_cast<int>(s.occluding_live_pixels);
  const double comparable = s.valid_live_pixels - s.occluding_live_pixels;
  result.inlier_ratio = comparable > 0 ? s.icp[28] / comparable : 0.0;
  result.icp_rms_m = s.icp[28] > 0 ? std::sqrt(s.icp[27] / s.icp[28]) : 0.0;
  result.rgb_rms = s.rgb[28] > 0 ? std::sqrt(s.rgb[27] / s.rgb[28]) : 0.0;
  result.live_intensity_gain = scales.live_gain;
  scales = next_iteration_scales(params, result, exposure_gain(s, params, scales.live_gain));
}

// The normal equations of the ICP term plus the weighted photometric term.
void combined_system(const LinearSystemSums& s, const TrackerParams& params, Matrix6d& H, Vector6d& b) {
  unpack_term(s.icp, H, b);
  if (params.use_photometric && s.rgb[28] > 0) {
    Matrix6d H_rgb;
    Vector6d b_rgb;
    unpack_term(s.rgb, H_rgb, b_rgb);
    H += params.photometric_weight * H_rgb;
    b += params.photometric_weight * b_rgb;
  }
}

// Why the converged pose is refused (`delta` = guess^-1 * pose: it moved too far from the guess;
// too few inliers), or empty.
std::string refusal(const TrackingResult& result, const Eigen::Isometry3d& delta, const TrackerParams& params) {
  const double moved_t = delta.translation().norm(), moved_r = rotation_angle_rad(delta);
  if (moved_t > params.max_translation_from_guess_m || moved_r > params.max_rotation_from_guess_deg * kRadPerDeg)
    return "moved too far from the guess: " + fmt(moved_t) + " m, " + fmt(moved_r / kRadPerDeg) + " deg";
  if (result.inlier_ratio < params.min_inlier_ratio)
    return "inlier ratio " + fmt(result.inlier_ratio) + " < " + fmt(params.min_inlier_ratio) + " (" +
           std::to_string(result.icp_inliers) + " of " + std::to_string(result.valid_live_pixels) +
           " valid live pixels, " + std::to_string(result.occluding_live_pixels) + " of them occluding)";
  return {};
}
}  // namespace

TrackingResult gauss_newton(const std::vector<long>& level_pixels, const SumsAtLevel& sums,
                            const Eigen::Isometry3d& guess, const TrackerParams& params) {
  GaussNewton loop(level_pixels, guess, params);
  while (loop.request()) {
    const GaussNewton::Request r = *loop.request();
    loop.take(sums(r.level, r.T_reference_live, r.scales));
  }
  return loop.result();
}

GaussNewton::GaussNewton(const std::vector<long>& level_pixels, const Eigen::Isometry3d& guess,
                         const TrackerParams& params)
    : level_pixels_(level_pixels), params_(params), guess_(guess), T_(guess), T_level_start_(guess) {
  result_.T_reference_live = guess;
  start_level(static_cast<int>(level_pixels.size()) - 1);
}

// Goes on at the finest level from `level` down that runs any iteration; finishes past level 0.
void GaussNewton::start_level(int level) {
  while (level >= 0 && params_.iterations_per_level[size_t(level)] <= 0) --level;
  if (level < 0) return finish();
  level_ = level;
  iteration_ = 0;
  T_level_start_ = T_;
  // Fewer pixels, fewer correspondences needed (but never fewer than two per unknown).
  const double pixel_share = static_cast<double>(level_pixels_[size_t(level)]) / static_cast<double>(level_pixels_[0]);
  min_correspondences_ = std::max(12.0, params_.min_correspondences * pixel_share);
  request_ = Request{level_, T_, scales_};
}

void GaussNewton::take(const LinearSystemSums& s) {
  if (!request_) throw Error("GaussNewton::take: the loop has finished");
  if (!evaluated_) {
    // The first sums measure the live frame's exposure; they are formed again with it when it
    // differs from the assumed one by more than 0.2% (half an intensity level at mid-grey).
    evaluated_ = true;
    const double gain = exposure_gain(s, params_, scales_.live_gain);
    if (std::abs(gain - scales_.live_gain) > 0.002) {
      scales_.live_gain = gain;
      request_ = Request{level_, T_, scales_};
      return;
    }
  }
  iterate(s);
}

void GaussNewton::iterate(const LinearSystemSums& s) {
  const std::string where = "level " + std::to_string(level_);
  take_statistics(s, params_, result_, scales_);
  if (level_ > 0 && s.icp[28] < params_.min_coarse_level_correspondences) return start_level(level_ - 1);
  if (s.icp[28] < min_correspondences_)
    return fail("too few ICP correspondences at " + where + ": " + std::to_string(result_.icp_inliers) + " < " +
                fmt(min_correspondences_));

  Matrix6d H;
  Vector6d b;
  combined_system(s, params_, H, b);
  if (!H.allFinite() || !b.allFinite()) return fail("non-finite linear system at " + where);
  result_.eigenvalue_ratio = balanced_eigenvalue_ratio(H);
  // A coarse level of a small object can be degenerate where the finer ones are not (a box face of
  // a few dozen pixels at 80x60): it is skipped, not the whole tracking failed.
  if (level_ > 0 && result_.eigenvalue_ratio < params_.min_eigenvalue_ratio) return start_level(level_ - 1);
  if (result_.eigenvalue_ratio < params_.min_eigenvalue_ratio)
    return fail("degenerate system at " + where + ": balanced eigenvalue ratio " + fmt(result_.eigenvalue_ratio) +
                " < " + fmt(params_.min_eigenvalue_ratio) + " (motion along some direction is unobservable)");

  const Vector6d xi = H.ldlt().solve(-b);
  if (!xi.allFinite()) return fail("non-finite update at " + where);
  const double step_t = xi.head<3>().norm(), step_r = xi.tail<3>().norm();
  const bool diverged = step_t > params_.max_step_translation_m || step_r > params_.max_step_rotation_deg * kRadPerDeg;
  // A coarse level can ask for a wild step where the finer ones do not (people covering most of a
  // 80x60 image): the level's steps are undone and the next finer level goes on from the pose it
  // started with; only the finest level's divergence fails the tracking.
  if (level_ > 0 && diverged) {
    T_ = T_level_start_;
    ++result_.skipped_diverging_levels;
    return start_level(level_ - 1);
  }
  if (diverged)
    return fail("diverged at " + where + ": step of " + fmt(step_t) + " m, " + fmt(step_r / kRadPerDeg) + " deg");
  T_ = orthonormalised(se3_exp(xi) * T_);
  const bool converged = step_t < params_.converged_translation_m && step_r < params_.converged_rotation_rad;
  if (converged || ++iteration_ >= params_.iterations_per_level[size_t(level_)]) return start_level(level_ - 1);
  request_ = Request{level_, T_, scales_};
}

void GaussNewton::fail(const std::string& reason) {
  request_.reset();
  result_.failed = true;
  result_.failure_reason = reason;
  result_.T_reference_live = guess_;
}

void GaussNewton::finish() {
  request_.reset();
  if (!evaluated_) return fail("no Gauss-Newton iterations configured");
  if (const std::string refused = refusal(result_, guess_.inverse() * T_, params_); !refused.empty())
    return fail(refused);
  result_.T_reference_live = T_;
}

}  // namespace cofusion::slam
