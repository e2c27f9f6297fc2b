#pragma once
// A small fixed scene for the renderer tests: a checkered floor (model 0), a sphere (model 1) and
// a box (model 2, posed away from the origin), as surfel clouds generated here, and a camera.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/surfel_cloud.h"
#include "renderer/image.h"
#include "renderer/view_renderer.h"

namespace cofusion::test {

// Writes `image` as a PNG file (tests only; the program writes screenshots atomically).
inline void write_png_file(const renderer::Image& image, const std::filesystem::path& path) {
  const std::vector<uint8_t> bytes = renderer::encode_png(image);
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

inline Surfel make_surfel(const Eigen::Vector3d& p, const Eigen::Vector3d& n, uint32_t rgba, float radius_m,
                          float confidence) {
  Surfel s{};
  s.px = static_cast<float>(p.x());
  s.py = static_cast<float>(p.y());
  s.pz = static_cast<float>(p.z());
  s.nx = static_cast<float>(n.x());
  s.ny = static_cast<float>(n.y());
  s.nz = static_cast<float>(n.z());
  s.radius_m = radius_m;
  s.confidence = confidence;
  s.colour_rgba8 = rgba;
  return s;
}

// Square patch centred at `centre`, spanned by unit vectors a and b, side `size_m`, grid `step_m`.
inline void add_patch(std::vector<Surfel>& out, const Eigen::Vector3d& centre, const Eigen::Vector3d& a,
                      const Eigen::Vector3d& b, double size_m, double step_m, uint32_t rgba_even, uint32_t rgba_odd) {
  const int n = static_cast<int>(std::round(size_m / step_m));
  const Eigen::Vector3d normal = a.cross(b).normalized();
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const Eigen::Vector3d p = centre + a * (i * step_m - size_m / 2) + b * (j * step_m - size_m / 2);
      const bool even = ((i * 5 / n) + (j * 5 / n)) % 2 == 0;  // a 5x5 checkerboard
      out.push_back(make_surfel(p, normal, even ? rgba_even : rgba_odd, static_cast<float>(0.75 * step_m),
                                static_cast<float>(1.0 + 10.0 * i / n)));
    }
}

inline std::vector<SurfelCloud> test_scene() {
  using renderer::rgba8;
  std::vector<SurfelCloud> clouds(3);
  // World: y down (like the cameras), floor at y = 0.3.
  clouds[0].model_id = 0;
  add_patch(clouds[0].surfels, {0, 0.3, 1.5}, {1, 0, 0}, {0, 0, 1}, 2.0, 0.02, rgba8(200, 190, 170),
            rgba8(90, 80, 70));
  clouds[1].model_id = 1;
  const Eigen::Vector3d centre(-0.2, 0.05, 1.4);
  const double r = 0.25;
  for (int i = 0; i <= 60; ++i)
    for (int j = 0; j < 120; ++j) {
      const double theta = M_PI * i / 60, phi = 2 * M_PI * j / 120;
      const Eigen::Vector3d n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      clouds[1].surfels.push_back(make_surfel(centre + r * n, n, rgba8(static_cast<uint32_t>(120 + 120 * n.y()), 40, 40),
                                              0.012f, static_cast<float>(1.0 + 9.0 * i / 60)));
    }
  clouds[2].model_id = 2;
  const double h = 0.1;
  const Eigen::Vector3d ex(1, 0, 0), ey(0, 1, 0), ez(0, 0, 1);
  add_patch(clouds[2].surfels, -h * ey, ez, ex, 2 * h, 0.01, rgba8(40, 170, 60), rgba8(30, 110, 200));
  add_patch(clouds[2].surfels, -h * ez, ex, ey, 2 * h, 0.01, rgba8(40, 170, 60), rgba8(30, 110, 200));
  add_patch(clouds[2].surfels, h * ex, ez, ey, 2 * h, 0.01, rgba8(40, 170, 60), rgba8(30, 110, 200));
  add_patch(clouds[2].surfels, -h * ex, ey, ez, 2 * h, 0.01, rgba8(40, 170, 60), rgba8(30, 110, 200));
  clouds[2].T_world_model = Eigen::Translation3d(0.35, 0.2, 1.2) * Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitY());
  return clouds;
}

inline renderer::VirtualCamera test_camera(int width, int height) {
  renderer::VirtualCamera cam;
  cam.intrinsics.width = width;
  cam.intrinsics.height = height;
  cam.intrinsics.fx = cam.intrinsics.fy = 0.8 * width;
  cam.intrinsics.cx = (width - 1) / 2.0;
  cam.intrinsics.cy = (height - 1) / 2.0;
  cam.T_world_view = renderer::look_at({0.9, -0.7, 0.1}, {0.0, 0.15, 1.45}, {0, -1, 0});
  return cam;
}

// Number of pixels where some channel differs by more than `tolerance`.
inline size_t mismatch_count(const renderer::Image& a, const renderer::Image& b, int tolerance) {
  size_t bad = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i)
    for (int c = 0; c < 32; c += 8) {
      const int d = static_cast<int>((a.rgba[i] >> c) & 0xFF) - static_cast<int>((b.rgba[i] >> c) & 0xFF);
      if (std::abs(d) > tolerance) {
        ++bad;
        break;
      }
    }
  return bad;
}

// Share of pixels where some channel differs by more than `tolerance`.
inline double mismatch_share(const renderer::Image& a, const renderer::Image& b, int tolerance) {
  return a.rgba.empty() ? 0.0 : static_cast<double>(mismatch_count(a, b, tolerance)) / static_cast<double>(a.rgba.size());
}

// The first pixel where some channel differs by more than `tolerance`, as "(x, y): a 0x.., b 0x..",
// for failure messages; "" when none does.
inline std::string first_mismatch(const renderer::Image& a, const renderer::Image& b, int tolerance) {
  for (size_t i = 0; i < a.rgba.size() && i < b.rgba.size(); ++i)
    for (int c = 0; c < 32; c += 8) {
      const int d = static_cast<int>((a.rgba[i] >> c) & 0xFF) - static_cast<int>((b.rgba[i] >> c) & 0xFF);
      if (std::abs(d) <= tolerance) continue;
      std::ostringstream out;
      out << "(" << i % a.width << ", " << i / a.width << "): " << std::hex << "0x" << a.rgba[i] << " against 0x"
          << b.rgba[i];
      return out.str();
    }
  return "";
}

}  // namespace cofusion::test
