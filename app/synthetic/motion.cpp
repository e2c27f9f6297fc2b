#include "synthetic/motion.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/error.h"
#include "synthetic/noise.h"

namespace cofusion::synthetic {

Pose interpolate(const KeyframedPath& path, double t_s) {
  const auto& keys = path.keyframes;
  if (keys.empty()) return Pose::Identity();
  if (t_s <= keys.front().t_s) return keys.front().pose;
  if (t_s >= keys.back().t_s) return keys.back().pose;
  // First keyframe strictly after t_s; keys are sorted by time.
  const auto next = std::upper_bound(keys.begin(), keys.end(), t_s,
                                     [](double t, const Keyframe& k) { return t < k.t_s; });
  const Keyframe& b = *next;
  const Keyframe& a = *(next - 1);
  const double span = b.t_s - a.t_s;
  double s = span > 0 ? (t_s - a.t_s) / span : 1.0;
  if (path.interpolation == Interpolation::kSmooth) s = s * s * (3 - 2 * s);
  const Eigen::Quaterniond qa(a.pose.linear()), qb(b.pose.linear());
  Pose out = Pose::Identity();
  out.linear() = qa.slerp(s, qb).normalized().toRotationMatrix();
  out.translation() = (1 - s) * a.pose.translation() + s * b.pose.translation();
  return out;
}

Pose camera_jitter(const JitterDesc& jitter, unsigned seed, double t_s) {
  if (jitter.translation_m <= 0 && jitter.rotation_deg <= 0) return Pose::Identity();
  // Three sines per degree of freedom; each has RMS amp / sqrt(2), so the sum of three independent
  // ones has RMS amp * sqrt(3/2): scale to make the total RMS the requested amplitude.
  constexpr int kSines = 3;
  const double norm = 1.0 / std::sqrt(kSines / 2.0);
  double v[6];
  for (int dof = 0; dof < 6; ++dof) {
    const double amp = dof < 3 ? jitter.translation_m : jitter.rotation_deg * std::numbers::pi / 180;
    double sum = 0;
    for (int k = 0; k < kSines; ++k) {
      const uint64_t h = hash_counter(seed, 0xC0FFEE, static_cast<uint64_t>(dof * kSines + k), 7);
      const double hz = jitter.min_hz + (jitter.max_hz - jitter.min_hz) * unit_float(static_cast<uint32_t>(h));
      const double phase = 2 * std::numbers::pi * unit_float(static_cast<uint32_t>(h >> 32));
      sum += std::sin(2 * std::numbers::pi * hz * t_s + phase);
    }
    v[dof] = amp * norm * sum;
  }
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  const Eigen::Vector3d w(v[3], v[4], v[5]);
  if (w.norm() > 0) T.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  return T;
}

Eigen::Matrix3d look_at_rotation(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                                 const Eigen::Vector3d& up_world) {
  const Eigen::Vector3d forward = target - eye;
  if (forward.norm() < 1e-9) throw Error("look_at target equals the camera position");
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d x_raw = z.cross(up_world);
  if (x_raw.norm() < 1e-6) throw Error("look_at direction is parallel to 'up'");
  const Eigen::Vector3d x = x_raw.normalized();  // camera right
  const Eigen::Vector3d y = z.cross(x);          // camera down
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return R;
}

}  // namespace cofusion::synthetic
