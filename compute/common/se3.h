#pragma once
// Rigid-motion helpers in double precision. A twist xi = (v, w): v translation part (metres),
// w rotation part (axis * angle, radians). Small motions compose on the LEFT:
// T <- exp(xi) * T, so d(exp(xi) * p)/dxi at 0 = [ I | -[p]x ].
#include <Eigen/Geometry>
#include <cmath>

namespace cofusion {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

inline Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}

// Exponential map of se(3).
inline Eigen::Isometry3d se3_exp(const Vector6d& xi) {
  const Eigen::Vector3d v = xi.head<3>(), w = xi.tail<3>();
  const double theta = w.norm();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity(), V = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d W = skew(w);
  if (theta > 1e-12) {
    R = Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
    V += (1 - std::cos(theta)) / (theta * theta) * W + (theta - std::sin(theta)) / (theta * theta * theta) * W * W;
  } else {
    R += W;
    V += 0.5 * W;
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = V * v;
  return T;
}

// Rotation angle of T in radians and translation length in metres: for convergence tests.
inline double rotation_angle_rad(const Eigen::Isometry3d& T) {
  return Eigen::AngleAxisd(T.rotation()).angle();
}

// Re-orthonormalises the rotation after many compositions (drift of double rounding).
inline Eigen::Isometry3d orthonormalised(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d out = T;
  out.linear() = Eigen::Quaterniond(T.rotation()).normalized().toRotationMatrix();
  return out;
}

}  // namespace cofusion
