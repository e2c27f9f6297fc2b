#include "eval/trajectory_metrics.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <tuple>

#include "common/error.h"

namespace cofusion::eval {
namespace {

std::string fmt_s(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Rotation angle of a rigid transform, clamped as compute_angle() does.
double rotation_angle_rad(const Pose& T) {
  const double c = (T.linear().trace() - 1.0) / 2.0;
  return std::acos(std::min(1.0, std::max(-1.0, c)));
}

std::vector<double> stamps_of(const Trajectory& trajectory) {
  std::vector<double> stamps;
  stamps.reserve(trajectory.size());
  for (const auto& p : trajectory) stamps.push_back(p.timestamp_s);
  return stamps;
}


// Rotation R maximising sum b_i^T R a_i, given W = sum a_i b_i^T (Horn / Kabsch, no reflection).
Eigen::Matrix3d rotation_from_correlation(const Eigen::Matrix3d& W) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(W.transpose(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;
  return svd.matrixU() * S * svd.matrixV().transpose();
}

struct TrackedPointFit {
  Pose A = Pose::Identity();
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  double cost = 0;  // sum of squared errors
};

double tracked_point_cost(const std::vector<Eigen::Vector3d>& g, const std::vector<const Pose*>& T_est, const Pose& A,
                          const Eigen::Vector3d& q) {
  double sum_sq = 0;
  for (std::size_t k = 0; k < g.size(); ++k) sum_sq += (A * (*T_est[k] * q) - g[k]).squaredNorm();
  return sum_sq;
}

// Levenberg-Marquardt on (rotation increment, t_A, q); each accepted step lowers the cost, so the
// result is never worse than the start. The damping also copes with objects that do not rotate,
// where q and t_A cannot be told apart.
TrackedPointFit refine_tracked_point(const std::vector<Eigen::Vector3d>& g, const std::vector<const Pose*>& T_est, Pose A,
                                     Eigen::Vector3d q, const ObjectTrajectoryParams& params) {
  const auto n = static_cast<double>(g.size());
  double cost = tracked_point_cost(g, T_est, A, q);
  double lambda = -1;
  for (int iteration = 0; iteration < params.max_iterations && cost > 0; ++iteration) {
    Eigen::Matrix<double, 9, 9> H = Eigen::Matrix<double, 9, 9>::Zero();
    Eigen::Matrix<double, 9, 1> b = Eigen::Matrix<double, 9, 1>::Zero();
    for (std::size_t k = 0; k < g.size(); ++k) {
      const Eigen::Vector3d x = *T_est[k] * q;
      const Eigen::Vector3d r = A * x - g[k];
      Eigen::Matrix3d x_hat;
      x_hat << 0, -x.z(), x.y(), x.z(), 0, -x.x(), -x.y(), x.x(), 0;
      Eigen::Matrix<double, 3, 9> J;
      J.block<3, 3>(0, 0) = -A.linear() * x_hat;              // d r / d rotation increment (right)
      J.block<3, 3>(0, 3) = Eigen::Matrix3d::Identity();       // d r / d t_A
      J.block<3, 3>(0, 6) = A.linear() * T_est[k]->linear();  // d r / d q
      H += J.transpose() * J;
      b += J.transpose() * r;
    }
    if (lambda < 0) lambda = 1e-6 * H.diagonal().maxCoeff();
    bool improved = false, converged = false;
    for (int attempt = 0; attempt < 30 && !improved; ++attempt) {
      Eigen::Matrix<double, 9, 9> H_damped = H;
      H_damped.diagonal().array() += lambda;
      const Eigen::Matrix<double, 9, 1> step = -H_damped.ldlt().solve(b);
      Pose A_new = A;
      const Eigen::Vector3d dtheta = step.head<3>();
      if (dtheta.norm() > 0) A_new.linear() = A.linear() * Eigen::AngleAxisd(dtheta.norm(), dtheta.normalized()).toRotationMatrix();
      A_new.translation() = A.translation() + step.segment<3>(3);
      const Eigen::Vector3d q_new = q + step.tail<3>();
      const double new_cost = tracked_point_cost(g, T_est, A_new, q_new);
      if (new_cost < cost) {
        improved = true;
        converged = std::sqrt(cost / n) - std::sqrt(new_cost / n) < params.convergence_rmse_m;
        A = A_new;
        q = q_new;
        cost = new_cost;
        lambda = std::max(lambda * 0.1, 1e-15);
      } else {
        lambda *= 10;
      }
    }
    if (!improved || converged) break;
  }
  A.linear() = Eigen::Quaterniond(A.linear()).normalized().toRotationMatrix();  // undo drift
  return {A, q, tracked_point_cost(g, T_est, A, q)};
}

// Hand-eye start: world-frame rotations since the first match satisfy
// R_gt(t) R_gt(t0)^T = R_A R_est(t) R_est(t0)^T R_A^T, so their rotation vectors are related by R_A;
// given R_A, (t_A, q) is a linear least-squares problem. nullopt when the object hardly rotates.
std::optional<std::pair<Pose, Eigen::Vector3d>> hand_eye_start(const std::vector<Eigen::Vector3d>& g,
                                                               const std::vector<const Pose*>& T_est, const Trajectory& gt,
                                                               const Trajectory& est,
                                                               const std::vector<TimestampMatch>& matches) {
  const Eigen::Matrix3d R_gt0 = gt[matches.front().first].T_world_x.linear();
  const Eigen::Matrix3d R_est0 = est[matches.front().second].T_world_x.linear();
  Eigen::Matrix3d W = Eigen::Matrix3d::Zero();
  double total_angle = 0;
  for (const auto& m : matches) {
    const Eigen::AngleAxisd w_gt(gt[m.first].T_world_x.linear() * R_gt0.transpose());
    const Eigen::AngleAxisd w_est(est[m.second].T_world_x.linear() * R_est0.transpose());
    W += (w_est.angle() * w_est.axis()) * (w_gt.angle() * w_gt.axis()).transpose();
    total_angle += w_gt.angle();
  }
  if (total_angle < 1e-6) return std::nullopt;
  Pose A = Pose::Identity();
  A.linear() = rotation_from_correlation(W);
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
  for (std::size_t k = 0; k < g.size(); ++k) {
    Eigen::Matrix<double, 3, 6> J;
    J.block<3, 3>(0, 0) = Eigen::Matrix3d::Identity();
    J.block<3, 3>(0, 3) = A.linear() * T_est[k]->linear();
    const Eigen::Vector3d y = g[k] - A.linear() * T_est[k]->translation();
    H += J.transpose() * J;
    b += J.transpose() * y;
  }
  H.diagonal().array() += 1e-12 * H.diagonal().maxCoeff();
  const Eigen::Matrix<double, 6, 1> z = H.ldlt().solve(b);
  A.translation() = z.head<3>();
  return std::make_pair(A, Eigen::Vector3d(z.tail<3>()));
}

}  // namespace

Trajectory sorted_unique(const Trajectory& trajectory) {
  Trajectory out = trajectory;
  // Stable sort keeps file order among equal stamps; then keep the last of each run.
  std::stable_sort(out.begin(), out.end(),
                   [](const TimedPose& a, const TimedPose& b) { return a.timestamp_s < b.timestamp_s; });
  Trajectory unique;
  unique.reserve(out.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (i + 1 < out.size() && out[i + 1].timestamp_s == out[i].timestamp_s) continue;
    unique.push_back(out[i]);
  }
  return unique;
}

std::vector<TimestampMatch> associate_timestamps(const Trajectory& first, const Trajectory& second,
                                                 const AssociationParams& params) {
  if (!(params.max_difference_s > 0)) throw Error("associate: max difference must be > 0 s");
  // Second trajectory's shifted stamps in sorted order, to find candidates by binary search.
  std::vector<std::pair<double, std::size_t>> shifted;
  shifted.reserve(second.size());
  for (std::size_t j = 0; j < second.size(); ++j) shifted.emplace_back(second[j].timestamp_s + params.offset_s, j);
  std::sort(shifted.begin(), shifted.end());

  struct Candidate {
    double dt, a, b;
    std::size_t i, j;
  };
  std::vector<Candidate> candidates;
  // Widened search window; the exact test below is the script's.
  const double window = params.max_difference_s * (1 + 1e-9) + 1e-12;
  for (std::size_t i = 0; i < first.size(); ++i) {
    const double a = first[i].timestamp_s;
    auto it = std::lower_bound(shifted.begin(), shifted.end(), std::make_pair(a - window, std::size_t{0}));
    for (; it != shifted.end() && it->first <= a + window; ++it) {
      const double b = second[it->second].timestamp_s;
      const double dt = std::abs(a - (b + params.offset_s));
      if (dt < params.max_difference_s) candidates.push_back({dt, a, b, i, it->second});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
    return std::tie(x.dt, x.a, x.b, x.i, x.j) < std::tie(y.dt, y.a, y.b, y.i, y.j);
  });
  std::vector<char> first_used(first.size(), 0), second_used(second.size(), 0);
  std::vector<TimestampMatch> matches;
  for (const auto& c : candidates) {
    if (first_used[c.i] || second_used[c.j]) continue;
    first_used[c.i] = second_used[c.j] = 1;
    matches.push_back({c.i, c.j});
  }
  std::sort(matches.begin(), matches.end(), [&](const TimestampMatch& x, const TimestampMatch& y) {
    return std::make_tuple(first[x.first].timestamp_s, second[x.second].timestamp_s, x.first) <
           std::make_tuple(first[y.first].timestamp_s, second[y.second].timestamp_s, y.first);
  });
  return matches;
}

Pose align_rigid(const std::vector<Eigen::Vector3d>& est_points, const std::vector<Eigen::Vector3d>& gt_points) {
  if (est_points.size() != gt_points.size())
    throw Error("rigid alignment: point counts differ (" + std::to_string(est_points.size()) + " vs " +
                std::to_string(gt_points.size()) + ")");
  if (est_points.size() < 2)
    throw Error("rigid alignment: needs at least 2 points, got " + std::to_string(est_points.size()));
  const double n = static_cast<double>(est_points.size());
  Eigen::Vector3d mean_est = Eigen::Vector3d::Zero(), mean_gt = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < est_points.size(); ++i) {
    mean_est += est_points[i];
    mean_gt += gt_points[i];
  }
  mean_est /= n;
  mean_gt /= n;
  // W = sum (est_i - mean_est)(gt_i - mean_gt)^T; with W^T = U S V^T the rotation est -> gt is
  // U diag(1, 1, +-1) V^T, the sign chosen so the result is a rotation, not a reflection.
  Eigen::Matrix3d W = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < est_points.size(); ++i)
    W += (est_points[i] - mean_est) * (gt_points[i] - mean_gt).transpose();
  Pose T_gt_est = Pose::Identity();
  T_gt_est.linear() = rotation_from_correlation(W);
  T_gt_est.translation() = mean_gt - T_gt_est.linear() * mean_est;
  return T_gt_est;
}

AteResult compute_ate(const Trajectory& gt_in, const Trajectory& est_in, const AteParams& params) {
  const Trajectory gt = sorted_unique(gt_in);
  const Trajectory est = sorted_unique(est_in);
  if (gt.empty()) throw Error("ATE: the ground-truth trajectory is empty");
  if (est.empty()) throw Error("ATE: the estimated trajectory is empty");
  const auto matches = associate_timestamps(gt, est, params.association);
  if (matches.size() < 2)
    throw Error("ATE: only " + std::to_string(matches.size()) + " timestamp pair(s) match within " +
                fmt_s(params.association.max_difference_s) + " s (need 2): do the trajectories belong to the same sequence?");
  std::vector<Eigen::Vector3d> p_est, p_gt;
  AteResult result;
  for (const auto& m : matches) {
    p_gt.push_back(gt[m.first].T_world_x.translation());
    p_est.push_back(est[m.second].T_world_x.translation());
    result.stamps_gt_s.push_back(gt[m.first].timestamp_s);
    result.stamps_est_s.push_back(est[m.second].timestamp_s);
  }
  result.T_gt_est = align_rigid(p_est, p_gt);
  for (std::size_t i = 0; i < p_est.size(); ++i) result.errors_m.push_back((result.T_gt_est * p_est[i] - p_gt[i]).norm());
  result.translation_m = summarize_errors(result.errors_m);
  return result;
}

std::size_t find_closest_index(const std::vector<double>& sorted, double value) {
  std::size_t begin = 0, end = sorted.size(), best = 0;
  double difference = std::abs(sorted[0] - value);
  while (begin < end) {
    const std::size_t middle = (begin + end) / 2;
    if (std::abs(sorted[middle] - value) < difference) {
      difference = std::abs(sorted[middle] - value);
      best = middle;
    }
    if (value == sorted[middle]) return middle;
    if (sorted[middle] > value)
      end = middle;
    else
      begin = middle + 1;
  }
  return best;
}

RpeResult compute_rpe(const Trajectory& gt_in, const Trajectory& est_in, const RpeParams& params) {
  const Trajectory gt = sorted_unique(gt_in);
  const Trajectory est = sorted_unique(est_in);
  if (gt.size() < 2) throw Error("RPE: the ground-truth trajectory needs at least 2 poses, has " + std::to_string(gt.size()));
  if (est.size() < 2) throw Error("RPE: the estimated trajectory needs at least 2 poses, has " + std::to_string(est.size()));
  if (!(params.delta > 0)) throw Error("RPE: delta must be > 0");
  const std::vector<double> stamps_gt = stamps_of(gt);
  const std::vector<double> stamps_est = stamps_of(est);

  // The script's overlap test: distinct estimated stamps reached by going est -> closest gt ->
  // closest est must be at least two.
  {
    std::vector<std::size_t> returned;
    for (const double t_est : stamps_est) {
      const double t_gt = stamps_gt[find_closest_index(stamps_gt, t_est + params.offset_s)];
      const std::size_t back = find_closest_index(stamps_est, t_gt - params.offset_s);
      if (std::find(returned.begin(), returned.end(), back) == returned.end()) returned.push_back(back);
      if (returned.size() >= 2) break;
    }
    if (returned.size() < 2) throw Error("RPE: the trajectories' timestamps hardly overlap: are they of the same sequence?");
  }

  std::vector<double> index_est;
  if (params.unit == RpeDeltaUnit::seconds) {
    index_est = stamps_est;
  } else {
    for (std::size_t i = 0; i < est.size(); ++i) index_est.push_back(static_cast<double>(i));
  }
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t i = 0; i < est.size(); ++i) {
    const std::size_t j = find_closest_index(index_est, index_est[i] + params.delta);
    // As the script: a pair whose partner is the last pose is dropped (it is also what a delta
    // past the end clamps to).
    if (j != est.size() - 1) pairs.emplace_back(i, j);
  }

  std::vector<double> gt_intervals;
  for (std::size_t i = 1; i < stamps_gt.size(); ++i) gt_intervals.push_back(stamps_gt[i] - stamps_gt[i - 1]);
  const double gt_max_time_difference_s = 2 * median_of(gt_intervals);

  RpeResult result;
  std::vector<double> trans_m, rot_deg;
  for (const auto& [i, j] : pairs) {
    const double t_est0 = stamps_est[i] + params.offset_s, t_est1 = stamps_est[j] + params.offset_s;
    const std::size_t g0 = find_closest_index(stamps_gt, t_est0);
    const std::size_t g1 = find_closest_index(stamps_gt, t_est1);
    if (std::abs(stamps_gt[g0] - t_est0) > gt_max_time_difference_s ||
        std::abs(stamps_gt[g1] - t_est1) > gt_max_time_difference_s)
      continue;
    // ominus(a, b) = a^-1 b; error = ominus(ominus(est1, est0), ominus(gt1, gt0)).
    const Pose motion_est = est[j].T_world_x.inverse() * est[i].T_world_x;
    const Pose motion_gt = gt[g1].T_world_x.inverse() * gt[g0].T_world_x;
    const Pose error = motion_est.inverse() * motion_gt;
    trans_m.push_back(error.translation().norm());
    rot_deg.push_back(rotation_angle_rad(error) * 180.0 / std::numbers::pi);
    result.stamps_est_s.push_back(stamps_est[i]);
  }
  if (trans_m.size() < 2)
    throw Error("RPE: only " + std::to_string(trans_m.size()) + " pose pair(s) " + fmt_s(params.delta) +
                (params.unit == RpeDeltaUnit::seconds ? " s" : " frames") + " apart have ground truth (need 2)");
  result.translation_m = summarize_errors(trans_m);
  result.rotation_deg = summarize_errors(rot_deg);
  return result;
}

Pose align_by_poses(const Trajectory& gt_in, const Trajectory& est_in, const AssociationParams& params) {
  const Trajectory gt = sorted_unique(gt_in), est = sorted_unique(est_in);
  const auto matches = associate_timestamps(gt, est, params);
  if (matches.empty()) throw Error("no matching timestamps between the two trajectories");
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const auto& m : matches) sum += gt[m.first].T_world_x.linear() * est[m.second].T_world_x.linear().transpose();
  // The rotation nearest the sum (maximising trace(R^T sum)).
  Pose T = Pose::Identity();
  T.linear() = rotation_from_correlation(sum.transpose());
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (const auto& m : matches) t += gt[m.first].T_world_x.translation() - T.linear() * est[m.second].T_world_x.translation();
  T.translation() = t / double(matches.size());
  return T;
}

namespace {

// The pose of a trajectory nearest to t_s (`stamps`: its sorted timestamps), or null when none lies
// within max_dt_s.
const Pose* nearest_pose(const Trajectory& trajectory, const std::vector<double>& stamps, double t_s, double max_dt_s) {
  if (stamps.empty()) return nullptr;
  const std::size_t k = find_closest_index(stamps, t_s);
  return std::abs(stamps[k] - t_s) <= max_dt_s ? &trajectory[k].T_world_x : nullptr;
}

// ObjectTrajectoryErrors (5): the object's centre at the first stamp with both cameras, in that
// camera, carried by the model's pose in the camera, against its true place in the true camera.
void add_camera_relative_drift(const Trajectory& gt, const Trajectory& est, const std::vector<TimestampMatch>& matches,
                               const CameraTrajectories& cameras_in, const AssociationParams& association,
                               ObjectTrajectoryErrors& out) {
  const Trajectory gt_camera = sorted_unique(cameras_in.gt), est_camera = sorted_unique(cameras_in.est);
  const std::vector<double> gt_stamps = stamps_of(gt_camera), est_stamps = stamps_of(est_camera);
  std::optional<Eigen::Vector3d> centre_in_model;  // the object's centre at the first stamp, in model coordinates
  std::vector<double> drift_m;
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const TimedPose& g = gt[matches[k].first];
    const TimedPose& e = est[matches[k].second];
    const Pose* gc = nearest_pose(gt_camera, gt_stamps, g.timestamp_s, association.max_difference_s);
    const Pose* ec = nearest_pose(est_camera, est_stamps, e.timestamp_s, association.max_difference_s);
    if (!gc || !ec) continue;
    const Pose T_camera_model = ec->inverse() * e.T_world_x;
    const Eigen::Vector3d centre_in_camera = (gc->inverse() * g.T_world_x).translation();
    if (!centre_in_model) centre_in_model = T_camera_model.inverse() * centre_in_camera;
    drift_m.push_back((T_camera_model * *centre_in_model - centre_in_camera).norm());
    out.drift_series[k].camera_relative_m = drift_m.back();
  }
  if (drift_m.size() > 1) drift_m.erase(drift_m.begin());  // the first is zero by construction, as in (4)
  else drift_m.clear();
  out.camera_relative_drift_m = summarize_errors(drift_m);
}

}  // namespace

ObjectTrajectoryErrors compute_object_trajectory_errors(const Trajectory& gt_object_in, const Trajectory& est_model_in,
                                                        const ObjectTrajectoryParams& params) {
  ObjectTrajectoryErrors out;
  out.origin_ate = compute_ate(gt_object_in, est_model_in, AteParams{params.association});

  const Trajectory gt = sorted_unique(gt_object_in);
  const Trajectory est = sorted_unique(est_model_in);
  const auto matches = associate_timestamps(gt, est, params.association);

  // Tracked point: minimise sum |A (T_est q) - g|^2 over the alignment A and the model-frame point q.
  std::vector<Eigen::Vector3d> g;
  std::vector<const Pose*> T_est;
  for (const auto& m : matches) {
    g.push_back(gt[m.first].T_world_x.translation());
    T_est.push_back(&est[m.second].T_world_x);
  }
  TrackedPointFit fit = refine_tracked_point(g, T_est, out.origin_ate.T_gt_est, Eigen::Vector3d::Zero(), params);
  // The origin alignment can be far from the right rotation for rotating objects (a local
  // minimum), so also start from the hand-eye rotation and keep the better fit.
  if (const auto start = hand_eye_start(g, T_est, gt, est, matches)) {
    const TrackedPointFit other = refine_tracked_point(g, T_est, start->first, start->second, params);
    if (other.cost < fit.cost) fit = other;
  }
  const Pose A = fit.A;
  const Eigen::Vector3d q = fit.q;
  const std::size_t n = matches.size();
  std::vector<Eigen::Vector3d> carried;
  for (std::size_t k = 0; k < n; ++k) carried.push_back(*T_est[k] * q);
  std::vector<double> point_errors;
  for (std::size_t k = 0; k < n; ++k) point_errors.push_back((A * carried[k] - g[k]).norm());
  out.tracked_point_m = summarize_errors(point_errors);
  out.gt_origin_in_model = q;
  out.T_gt_est_tracked_point = A;

  // Relative motion from the first matched time.
  const Pose& est0 = est[matches.front().second].T_world_x;
  const Pose& gt0 = gt[matches.front().first].T_world_x;
  std::vector<double> trans_m, rot_deg;
  for (std::size_t k = 1; k < matches.size(); ++k) {
    const Pose motion_est = est0.inverse() * est[matches[k].second].T_world_x;
    const Pose motion_gt = gt0.inverse() * gt[matches[k].first].T_world_x;
    const Pose error = motion_est.inverse() * motion_gt;
    trans_m.push_back(error.translation().norm());
    rot_deg.push_back(rotation_angle_rad(error) * 180.0 / std::numbers::pi);
  }
  out.relative_translation_m = summarize_errors(trans_m);
  out.relative_rotation_deg = summarize_errors(rot_deg);

  // Drift since the first matched time, in the world.
  const Pose W = params.T_gt_est_world.value_or(A);
  out.drift_in_given_world = params.T_gt_est_world.has_value();
  // In a given world the tracked point is the object's own origin at the first matched time,
  // carried by the model's motion from there (no per-object fit: a fitted point absorbs part of
  // a symmetric object's unobservable turn, or adds a turn's lever arm where the fit is off).
  if (out.drift_in_given_world) {
    const Eigen::Vector3d q0 = T_est[0]->inverse() * (W.inverse() * g[0]);
    for (std::size_t k = 0; k < n; ++k) carried[k] = *T_est[k] * q0;
  }
  const Eigen::Vector3d error0 = W * carried[0] - g[0];
  const Eigen::Matrix3d R_est0 = T_est[0]->linear(), R_gt0 = gt[matches.front().first].T_world_x.linear();
  std::vector<double> drift_m, drift_deg;
  out.drift_series.push_back({gt[matches.front().first].timestamp_s, 0.0, 0.0});
  for (std::size_t k = 1; k < n; ++k) {
    drift_m.push_back((W * carried[k] - g[k] - error0).norm());
    const Eigen::Matrix3d turned_est = W.linear() * T_est[k]->linear() * R_est0.transpose() * W.linear().transpose();
    const Eigen::Matrix3d turned_gt = gt[matches[k].first].T_world_x.linear() * R_gt0.transpose();
    drift_deg.push_back(Eigen::AngleAxisd(turned_est.transpose() * turned_gt).angle() * 180.0 / std::numbers::pi);
    out.drift_series.push_back({gt[matches[k].first].timestamp_s, drift_m.back(), drift_deg.back()});
  }
  out.drift_translation_m = summarize_errors(drift_m);
  out.drift_rotation_deg = summarize_errors(drift_deg);
  if (params.cameras) add_camera_relative_drift(gt, est, matches, *params.cameras, params.association, out);
  return out;
}

}  // namespace cofusion::eval
