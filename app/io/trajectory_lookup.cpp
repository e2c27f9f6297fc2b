#include "io/trajectory_lookup.h"

#include <algorithm>
#include <cmath>

namespace cofusion {

Pose interpolate_pose(const Pose& a, const Pose& b, double alpha) {
  const Eigen::Quaterniond qa(a.rotation());
  const Eigen::Quaterniond qb(b.rotation());
  Pose out = Pose::Identity();
  out.linear() = qa.slerp(alpha, qb).toRotationMatrix();
  out.translation() = (1.0 - alpha) * a.translation() + alpha * b.translation();
  return out;
}

std::optional<Pose> pose_at(const Trajectory& trajectory, double t, double max_dt_s) {
  if (trajectory.empty() || !std::isfinite(t)) return std::nullopt;
  // First sample at or after t.
  const auto after = std::lower_bound(trajectory.begin(), trajectory.end(), t,
                                      [](const TimedPose& p, double time) { return p.timestamp_s < time; });
  const bool has_after = after != trajectory.end();
  const bool has_before = after != trajectory.begin();
  const double dt_after = has_after ? after->timestamp_s - t : INFINITY;
  const double dt_before = has_before ? t - std::prev(after)->timestamp_s : INFINITY;
  if (dt_after == 0.0) return after->T_world_x;
  if (dt_before <= max_dt_s && dt_after <= max_dt_s) {
    const auto& a = *std::prev(after);
    const double alpha = dt_before / (after->timestamp_s - a.timestamp_s);
    return interpolate_pose(a.T_world_x, after->T_world_x, alpha);
  }
  if (dt_before <= max_dt_s && dt_before <= dt_after) return std::prev(after)->T_world_x;
  if (dt_after <= max_dt_s) return after->T_world_x;
  return std::nullopt;
}

}  // namespace cofusion
