#pragma once
// A small analytic scene for the multi-model kernel tests: a room corner (planes) and spheres
// that can be moved independently, ray-cast from any camera pose into depth, an intensity texture
// attached to each primitive (so it moves with it) and which primitive each pixel sees.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "common/intrinsics.h"
#include "kernels/image.h"

namespace cofusion::test::moving_scene {

struct Size {
  int width, height;
};
// Edge sizes of the GPU-vs-CPU comparisons.
inline const Size kEdgeSizes[] = {{1, 1}, {2, 3}, {37, 23}, {160, 120}, {640, 480}};
inline std::string name(Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

inline Intrinsics intrinsics_for(Size s) {
  Intrinsics k;
  k.width = s.width, k.height = s.height;
  k.fx = 525.0 * s.width / 640.0 + 1.0;
  k.fy = k.fx + 0.5;
  k.cx = (s.width - 1) / 2.0 + 0.25;
  k.cy = (s.height - 1) / 2.0 - 0.25;
  return k;
}

struct Plane {
  Eigen::Vector3d n;  // unit normal; points x with n.x = d
  double d;
};
struct Sphere {
  Eigen::Vector3d centre;  // world frame, metres
  double radius;
};
struct Scene {
  std::vector<Plane> planes;
  std::vector<Sphere> spheres;  // sphere k has primitive id k + 1; planes are id 0
};

// World frame = a camera at the origin looking along +z (y down): back wall, floor, a side wall,
// and one sphere in front of them.
inline Scene room(const Eigen::Vector3d& sphere_centre = {0.15, 0.05, 1.6}) {
  Scene s;
  s.planes = {{{0, 0, 1}, 2.8}, {{0, 1, 0}, 0.8}, {Eigen::Vector3d(0.8, 0, -0.6), -1.9}};
  s.spheres = {{sphere_centre, 0.3}};
  return s;
}

// Texture in a primitive's own frame (metres), in [0, 255].
inline double texture(const Eigen::Vector3d& p) {
  return 128 + 60 * std::sin(7.0 * p.x() + 0.3) * std::cos(5.0 * p.y()) + 40 * std::sin(9.0 * p.z() + 1.1);
}

struct View {
  kernels::Image<float> depth_m;    // camera-frame z, 0 = no hit
  kernels::Image<float> intensity;  // [0, 255]
  kernels::Image<uint32_t> id;      // primitive id per pixel (0 planes, k sphere k - 1), 0xFFFFFFFF no hit
};

inline View render(const Scene& scene, const Intrinsics& k, const Eigen::Isometry3d& T_world_camera) {
  View view{kernels::Image<float>(k.width, k.height), kernels::Image<float>(k.width, k.height),
            kernels::Image<uint32_t>(k.width, k.height, 0xFFFFFFFFu)};
  const Eigen::Vector3d o = T_world_camera.translation();
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      // Camera-frame ray with z = 1: the ray parameter is the camera-frame depth.
      const Eigen::Vector3d dir = T_world_camera.linear() * Eigen::Vector3d((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
      double best = 1e9;
      uint32_t id = 0xFFFFFFFFu;
      Eigen::Vector3d local;
      for (const auto& pl : scene.planes) {
        const double den = pl.n.dot(dir);
        if (std::abs(den) < 1e-12) continue;
        const double t = (pl.d - pl.n.dot(o)) / den;
        if (t > 0.1 && t < best) best = t, id = 0, local = o + t * dir;
      }
      for (size_t s = 0; s < scene.spheres.size(); ++s) {
        const auto& sp = scene.spheres[s];
        const Eigen::Vector3d oc = o - sp.centre;
        const double a = dir.squaredNorm(), b = oc.dot(dir), c = oc.squaredNorm() - sp.radius * sp.radius;
        const double disc = b * b - a * c;
        if (disc < 0) continue;
        const double t = (-b - std::sqrt(disc)) / a;
        if (t > 0.1 && t < best) best = t, id = uint32_t(s + 1), local = o + t * dir - sp.centre;
      }
      if (best > 5.0) continue;
      view.depth_m.at(x, y) = float(best);
      view.intensity.at(x, y) = float(std::clamp(texture(local), 0.0, 255.0));
      view.id.at(x, y) = id;
    }
  return view;
}

inline Eigen::Isometry3d pose(double angle_rad, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

}  // namespace cofusion::test::moving_scene
