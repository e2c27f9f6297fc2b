#include "slam/observed_motion.h"

#include <algorithm>
#include <cmath>

#include "shared/depth_noise.h"

namespace cofusion::slam {
namespace {

float grey(const uint8_t* rgb, size_t i) {
  return float(int(rgb[3 * i]) + int(rgb[3 * i + 1]) + int(rgb[3 * i + 2])) / (3.0f * 255.0f);
}

// The pixel a camera-frame point projects to, or -1 outside the image / behind the camera.
long project(const Eigen::Vector3f& q, const Intrinsics& k) {
  if (!(q.z() > 0.0f)) return -1;
  const long u = std::lround(k.fx * q.x() / q.z() + k.cx), v = std::lround(k.fy * q.y() / q.z() + k.cy);
  if (u < 0 || v < 0 || u >= k.width || v >= k.height) return -1;
  return v * long(k.width) + u;
}

struct Match {
  long pixel = -1;        // -1: no live depth there
  bool depth = false;     // within the depth noise
  bool occluded = false;  // the live surface lies in front of the point, beyond the noise
  float intensity = 0.0f;
};

Match match(const ObservedPoint& pt, const Eigen::Isometry3f& T_camera_world, const float* depth_m,
            const Intrinsics& k, float depth_sigmas) {
  const Eigen::Vector3f q = T_camera_world * pt.p_world;
  Match m;
  m.pixel = project(q, k);
  if (m.pixel < 0) return m;
  const float z = depth_m[m.pixel];
  if (!(z > 0.0f)) {
    m.pixel = -1;
    return m;
  }
  const float tolerance_m = depth_sigmas * gpu_layout::depth_noise_sigma_m(q.z());
  m.depth = std::abs(z - q.z()) <= tolerance_m;
  m.occluded = z < q.z() - tolerance_m;
  return m;
}

}  // namespace

std::vector<ObservedPoint> sample_region_points(const std::vector<size_t>& pixels, const float* depth_m,
                                                const uint8_t* rgb, const Intrinsics& k,
                                                const Eigen::Isometry3d& T_world_camera, int count) {
  std::vector<ObservedPoint> points;
  if (count <= 0 || pixels.empty()) return points;
  const size_t step = std::max<size_t>(1, pixels.size() / size_t(count));
  const Eigen::Isometry3f T = T_world_camera.cast<float>();
  for (size_t j = 0; j < pixels.size() && points.size() < size_t(count); j += step) {
    const size_t i = pixels[j];
    const float z = depth_m[i];
    if (!(z > 0.0f) || !std::isfinite(z)) continue;
    const float u = float(i % size_t(k.width)), v = float(i / size_t(k.width));
    const Eigen::Vector3f q((u - float(k.cx)) * z / float(k.fx), (v - float(k.cy)) * z / float(k.fy), z);
    points.push_back({T * q, grey(rgb, i)});
  }
  return points;
}

ObservedShares observed_shares(const std::vector<ObservedPoint>& points, const Eigen::Isometry3d& motion_world,
                               const float* depth_m, const uint8_t* rgb, const Intrinsics& k,
                               const Eigen::Isometry3d& T_world_camera, const ObservedMotionParams& p) {
  ObservedShares shares;
  if (points.empty()) return shares;
  const Eigen::Isometry3f T_camera_world = T_world_camera.inverse().cast<float>();
  const Eigen::Isometry3f T_moved = T_camera_world * motion_world.cast<float>();
  std::vector<Match> moved(points.size()), still(points.size());
  double live_sum = 0.0, point_sum = 0.0;
  for (size_t j = 0; j < points.size(); ++j) {
    moved[j] = match(points[j], T_moved, depth_m, k, p.depth_sigmas);
    still[j] = match(points[j], T_camera_world, depth_m, k, p.depth_sigmas);
    for (Match* m : {&moved[j], &still[j]})
      if (m->depth) m->intensity = grey(rgb, size_t(m->pixel));
    if (moved[j].depth) {
      live_sum += moved[j].intensity;
      point_sum += points[j].intensity;
    }
  }
  // The live frame's exposure relative to the spawn frame's (1 when nothing matched).
  const float gain = live_sum > 0.0 && point_sum > 0.0 ? float(point_sum / live_sum) : 1.0f;
  // Only points both hypotheses put in view with live depth, unoccluded, count: one that the
  // motion keeps in view (a drift that follows the camera's pan) and standing still does not is no
  // evidence, nor one that something else hides (a person walking past where it was); a point
  // is refuted where the frame sees a surface behind it or another colour.
  size_t n = 0, n_moved = 0, n_still = 0;
  for (size_t j = 0; j < points.size(); ++j) {
    if (moved[j].pixel < 0 || still[j].pixel < 0 || moved[j].occluded || still[j].occluded) continue;
    const auto explained = [&](const Match& m) {
      return m.depth && std::abs(gain * m.intensity - points[j].intensity) <= p.max_intensity_diff;
    };
    ++n;
    n_moved += explained(moved[j]);
    n_still += explained(still[j]);
  }
  shares.counted = double(n) / double(points.size());
  if (n == 0) return shares;
  shares.moved = double(n_moved) / double(n);
  shares.still = double(n_still) / double(n);
  return shares;
}

bool motion_shows(const ObservedShares& s, const ObservedMotionParams& p) {
  return s.counted >= p.min_counted && s.moved > 0.0 && s.still <= p.max_still_ratio * s.moved;
}

SpawnEvidence record_spawn(const std::vector<size_t>& region_pixels, const float* depth_m, const uint8_t* rgb,
                           const Intrinsics& k, const Eigen::Isometry3d& T_world_camera,
                           const ObservedMotionParams& p) {
  SpawnEvidence e;
  e.points = sample_region_points(region_pixels, depth_m, rgb, k, T_world_camera, p.points);
  if (e.points.empty()) return e;
  const size_t n = size_t(k.width) * size_t(k.height);
  e.depth_m.assign(depth_m, depth_m + n);
  e.rgb.assign(rgb, rgb + 3 * n);
  e.T_world_camera = T_world_camera;
  return e;
}

bool motion_observed(const SpawnEvidence& spawn, const std::vector<size_t>& current_pixels,
                     const Eigen::Isometry3d& motion_world, const float* depth_m, const uint8_t* rgb,
                     const Intrinsics& k, const Eigen::Isometry3d& T_world_camera, const ObservedMotionParams& p) {
  if (spawn.points.empty()) return true;
  if (motion_shows(observed_shares(spawn.points, motion_world, depth_m, rgb, k, T_world_camera, p), p)) return true;
  const std::vector<ObservedPoint> now = sample_region_points(current_pixels, depth_m, rgb, k, T_world_camera, p.points);
  return motion_shows(observed_shares(now, motion_world.inverse(), spawn.depth_m.data(), spawn.rgb.data(), k,
                                      spawn.T_world_camera, p),
                      p);
}

}  // namespace cofusion::slam
