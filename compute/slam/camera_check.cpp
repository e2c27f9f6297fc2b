#include "slam/camera_check.h"

#include <cmath>

namespace cofusion::slam {

double depth_fit(const float* depth_live_m, const float* depth_reference_m, const Intrinsics& intrinsics,
                 const Eigen::Isometry3d& T_reference_live, const CameraCheckParams& params) {
  const int w = intrinsics.width, h = intrinsics.height, step = std::max(1, params.step_px);
  const Eigen::Matrix3d R = T_reference_live.linear();
  const Eigen::Vector3d t = T_reference_live.translation();
  long with_depth = 0, fitting = 0;
  for (int y = 0; y < h; y += step)
    for (int x = 0; x < w; x += step) {
      const float z = depth_live_m[size_t(y) * size_t(w) + size_t(x)];
      if (!(z > 0.0f)) continue;  // also NaN
      ++with_depth;
      const Eigen::Vector3d p((x - intrinsics.cx) * z / intrinsics.fx, (y - intrinsics.cy) * z / intrinsics.fy, z);
      const Eigen::Vector3d q = R * p + t;
      if (!(q.z() > 0.0)) continue;
      const double u = std::round(intrinsics.fx * q.x() / q.z() + intrinsics.cx);
      const double v = std::round(intrinsics.fy * q.y() / q.z() + intrinsics.cy);
      if (!(u >= 0.0 && v >= 0.0 && u < w && v < h)) continue;
      const float z_ref = depth_reference_m[size_t(v) * size_t(w) + size_t(u)];
      if (z_ref > 0.0f && std::abs(double(z_ref) - q.z()) <= params.tolerance_rel * q.z() + params.tolerance_m) ++fitting;
    }
  return with_depth > 0 ? double(fitting) / double(with_depth) : 0.0;
}

CameraDecision decide_camera_motion(const CameraFits& fits, bool tracking_failed, bool refused_poses_agree,
                                    double last_fit, const CameraCheckParams& params) {
  CameraDecision d;
  if (!tracking_failed && (!fits.refused(params.min_fit_ratio) || refused_poses_agree)) return d;
  if (tracking_failed && fits.start < params.min_fit_ratio * last_fit) {
    d.verdict = CameraVerdict::kLost;
    return d;
  }
  d.verdict = CameraVerdict::kReplaced;
  d.motion = fits.from_guess ? scaled_motion(fits.guess, params.replaced_motion_scale) : Eigen::Isometry3d::Identity();
  return d;
}

Eigen::Isometry3d scaled_motion(const Eigen::Isometry3d& T, double scale) {
  const Eigen::AngleAxisd r(T.rotation());
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = Eigen::AngleAxisd(scale * r.angle(), r.axis()).toRotationMatrix();
  out.translation() = scale * T.translation();
  return out;
}

Eigen::Isometry3d motion_towards(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to, double gain) {
  return from * scaled_motion(from.inverse() * to, gain);
}

}  // namespace cofusion::slam
