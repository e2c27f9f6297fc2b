#include "slam/region_rigidity.h"

#include <cmath>
#include <optional>

#include <Eigen/Dense>

namespace cofusion::slam {
namespace {

bool has_depth(float d) { return std::isfinite(d) && d > 0.f; }

Eigen::Vector3d point_at(const float* depth_m, const Intrinsics& k, int x, int y) {
  const double z = depth_m[size_t(y) * size_t(k.width) + size_t(x)];
  return {(x - k.cx) / k.fx * z, (y - k.cy) / k.fy * z, z};
}

// The previous frame's point and normal (facing the camera) at pixel (x, y), from its four
// neighbours; nullopt at the border, without depth or across a depth edge.
std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> point_and_normal(const float* depth_m, const Intrinsics& k,
                                                                            int x, int y, double max_step_m) {
  if (x < 1 || y < 1 || x >= k.width - 1 || y >= k.height - 1) return std::nullopt;
  const auto d = [&](int u, int v) { return depth_m[size_t(v) * size_t(k.width) + size_t(u)]; };
  const float c = d(x, y);
  for (const float n : {d(x - 1, y), d(x + 1, y), d(x, y - 1), d(x, y + 1)})
    if (!has_depth(n) || !has_depth(c) || std::abs(n - c) > max_step_m) return std::nullopt;
  const Eigen::Vector3d dx = point_at(depth_m, k, x + 1, y) - point_at(depth_m, k, x - 1, y);
  const Eigen::Vector3d dy = point_at(depth_m, k, x, y + 1) - point_at(depth_m, k, x, y - 1);
  Eigen::Vector3d n = dx.cross(dy);
  if (n.norm() < 1e-12) return std::nullopt;
  n.normalize();
  const Eigen::Vector3d p = point_at(depth_m, k, x, y);
  if (n.dot(p) > 0) n = -n;
  return std::pair{p, n};
}

// Where `q` (previous camera) lands in the previous image, or nullopt outside it.
std::optional<std::pair<int, int>> project(const Eigen::Vector3d& q, const Intrinsics& k) {
  if (q.z() <= 0) return std::nullopt;
  const int x = static_cast<int>(std::lround(q.x() / q.z() * k.fx + k.cx));
  const int y = static_cast<int>(std::lround(q.y() / q.z() * k.fy + k.cy));
  if (x < 0 || y < 0 || x >= k.width || y >= k.height) return std::nullopt;
  return std::pair{x, y};
}

}  // namespace

RegionRigidity region_rigidity(const float* depth_current_m, const float* depth_previous_m, const Intrinsics& intrinsics,
                               const std::vector<size_t>& pixels, const Eigen::Isometry3d& T_previous_current_guess,
                               const RegionRigidityParams& params) {
  std::vector<Eigen::Vector3d> points;
  for (size_t i = 0; i < pixels.size(); i += size_t(std::max(1, params.step))) {
    const int x = int(pixels[i] % size_t(intrinsics.width)), y = int(pixels[i] / size_t(intrinsics.width));
    if (has_depth(depth_current_m[pixels[i]])) points.push_back(point_at(depth_current_m, intrinsics, x, y));
  }
  RegionRigidity out;
  out.points = int(points.size());
  Eigen::Isometry3d T = T_previous_current_guess;
  for (int it = 0; it <= params.iterations; ++it) {
    Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
    out.in_view = out.aligned = 0;
    for (const Eigen::Vector3d& p : points) {
      const Eigen::Vector3d q = T * p;
      const auto px = project(q, intrinsics);
      if (!px) continue;
      ++out.in_view;
      const auto pn = point_and_normal(depth_previous_m, intrinsics, px->first, px->second, params.normal_max_depth_step_m);
      if (!pn || (q - pn->first).norm() > params.association_m) continue;
      ++out.aligned;
      const double r = pn->second.dot(q - pn->first);
      Eigen::Matrix<double, 6, 1> J;
      J << q.cross(pn->second), pn->second;
      const double w = std::abs(r) <= params.huber_m ? 1.0 : params.huber_m / std::abs(r);
      A += w * J * J.transpose();
      b -= w * J * r;
    }
    if (it == params.iterations || out.aligned < 6) break;
    // A little damping: what the region's shape leaves unconstrained (a ball's rotation about its
    // centre, a wall's sliding) stays where the guess put it instead of wandering off.
    A.diagonal().array() += 1e-3 * A.trace() / 6.0 + 1e-9;
    const Eigen::Matrix<double, 6, 1> x = A.ldlt().solve(b);
    if (!x.allFinite()) break;
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    const double angle = x.head<3>().norm();
    if (angle > 0) step.linear() = Eigen::AngleAxisd(angle, x.head<3>() / angle).toRotationMatrix();
    step.translation() = x.tail<3>();
    T = step * T;
  }
  out.T_previous_current = T;
  return out;
}

}  // namespace cofusion::slam
