#include "renderer/overlay.h"

#include <array>
#include <cmath>
#include <cstdlib>

#include "renderer/font5x7.h"

namespace cofusion::renderer {

ModelBox bounding_box(const SurfelCloud& cloud) {
  ModelBox box;
  box.model_id = cloud.model_id;
  box.T_world_model = cloud.T_world_model;
  for (const auto& s : cloud.surfels) box.bounds_model.extend(Eigen::Vector3d(s.px, s.py, s.pz));
  return box;
}

std::string model_label(int model_id, const std::string& class_name) {
  return class_name.empty() ? std::to_string(model_id) : std::to_string(model_id) + " " + class_name;
}

void draw_line(Image& image, int x0, int y0, int x1, int y1, uint32_t rgba8) {
  const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  int err = dx + dy;
  for (;;) {
    if (image.contains(x0, y0)) image.at(x0, y0) = rgba8;
    if (x0 == x1 && y0 == y1) break;
    const int e2 = 2 * err;
    if (e2 >= dy) {
      err += dy;
      x0 += sx;
    }
    if (e2 <= dx) {
      err += dx;
      y0 += sy;
    }
  }
}

namespace {
// Liang-Barsky: clips the segment to [lo, hi] in x and y; false when nothing is left. Keeps the
// integer Bresenham loop short however far outside the image the projected ends are.
bool clip_segment(Eigen::Vector2d& a, Eigen::Vector2d& b, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  double t0 = 0, t1 = 1;
  const Eigen::Vector2d d = b - a;
  const std::array<double, 4> p{-d.x(), d.x(), -d.y(), d.y()};
  const std::array<double, 4> q{a.x() - lo.x(), hi.x() - a.x(), a.y() - lo.y(), hi.y() - a.y()};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0) {
      if (q[i] < 0) return false;
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0)
      t0 = std::max(t0, t);
    else
      t1 = std::min(t1, t);
    if (t0 > t1) return false;
  }
  const Eigen::Vector2d a0 = a;
  a = a0 + t0 * d;
  b = a0 + t1 * d;
  return true;
}
}  // namespace

void draw_world_line(Image& image, const VirtualCamera& camera, const Eigen::Vector3d& a_world,
                     const Eigen::Vector3d& b_world, uint32_t rgba8, double near_m) {
  const Eigen::Isometry3d T_view_world = camera.T_world_view.inverse();
  Eigen::Vector3d a = T_view_world * a_world, b = T_view_world * b_world;
  if (!a.allFinite() || !b.allFinite()) return;
  if (a.z() < near_m && b.z() < near_m) return;
  // Clip at the near plane so points behind the camera do not project mirrored.
  if (a.z() < near_m) a = a + (b - a) * ((near_m - a.z()) / (b.z() - a.z()));
  if (b.z() < near_m) b = b + (a - b) * ((near_m - b.z()) / (a.z() - b.z()));
  const auto& K = camera.intrinsics;
  auto project = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector2d(K.fx * p.x() / p.z() + K.cx, K.fy * p.y() / p.z() + K.cy);
  };
  Eigen::Vector2d pa = project(a), pb = project(b);
  if (!clip_segment(pa, pb, Eigen::Vector2d(-1, -1), Eigen::Vector2d(image.width, image.height))) return;
  draw_line(image, static_cast<int>(std::lround(pa.x())), static_cast<int>(std::lround(pa.y())),
            static_cast<int>(std::lround(pb.x())), static_cast<int>(std::lround(pb.y())), rgba8);
}

bool glyph_pixel(char c, int col, int row) {
  if (col < 0 || col > 4 || row < 0 || row > 6) return false;
  int code = static_cast<unsigned char>(c);
  if (code < 0x20 || code > 0x7E) code = '?';
  return (font5x7::kGlyphs[static_cast<size_t>(code - 0x20) * 5 + col] >> row) & 1;
}

int text_width_px(std::string_view text, int scale) {
  return text.empty() ? 0 : (static_cast<int>(text.size()) * kGlyphAdvancePx - 1) * scale;
}

void draw_text(Image& image, int x, int y, std::string_view text, uint32_t rgba8, int scale) {
  if (scale < 1) scale = 1;
  constexpr uint32_t shadow = 0xFF000000u;
  // Shadow first (one font pixel down-right), then the glyphs.
  for (int pass = 0; pass < 2; ++pass) {
    const int off = pass == 0 ? scale : 0;
    const uint32_t colour = pass == 0 ? shadow : rgba8;
    for (size_t i = 0; i < text.size(); ++i) {
      const int gx = x + static_cast<int>(i) * kGlyphAdvancePx * scale + off;
      for (int col = 0; col < 5; ++col)
        for (int row = 0; row < 7; ++row) {
          if (!glyph_pixel(text[i], col, row)) continue;
          for (int sy = 0; sy < scale; ++sy)
            for (int sx = 0; sx < scale; ++sx) {
              const int px = gx + col * scale + sx, py = y + off + row * scale + sy;
              if (image.contains(px, py)) image.at(px, py) = colour;
            }
        }
    }
  }
}

namespace {
// The label just above the highest of the box's corners in front of the camera, left-aligned on it.
void draw_box_label(Image& image, const VirtualCamera& camera, const std::array<Eigen::Vector3d, 8>& corners_world,
                    const std::string& label, uint32_t rgba8, double near_m = 0.01) {
  const Eigen::Isometry3d T_view_world = camera.T_world_view.inverse();
  const auto& K = camera.intrinsics;
  std::optional<Eigen::Vector2d> top;
  for (const auto& corner_world : corners_world) {
    const Eigen::Vector3d p = T_view_world * corner_world;
    if (!p.allFinite() || p.z() < near_m) continue;
    const Eigen::Vector2d px(K.fx * p.x() / p.z() + K.cx, K.fy * p.y() / p.z() + K.cy);
    if (!top || px.y() < top->y()) top = px;
  }
  if (!top || !top->allFinite() || std::abs(top->x()) > 1e6 || std::abs(top->y()) > 1e6) return;
  draw_text(image, static_cast<int>(std::lround(top->x())), static_cast<int>(std::lround(top->y())) - kLineHeightPx,
            label, rgba8, 1);
}
}  // namespace

void draw_overlay(Image& image, const VirtualCamera& camera, const Overlay& overlay) {
  for (size_t i = 1; i < overlay.trajectory_world.size(); ++i)
    draw_world_line(image, camera, overlay.trajectory_world[i - 1], overlay.trajectory_world[i],
                    overlay.trajectory_rgba8);
  for (const auto& box : overlay.boxes) {
    if (box.bounds_model.isEmpty()) continue;
    std::array<Eigen::Vector3d, 8> corners;
    for (int k = 0; k < 8; ++k)
      corners[k] = box.T_world_model * box.bounds_model.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k));
    // Corner k has bit 0 = x max, bit 1 = y max, bit 2 = z max: edges join corners one bit apart.
    for (int k = 0; k < 8; ++k)
      for (int bit = 1; bit < 8; bit <<= 1)
        if (!(k & bit)) draw_world_line(image, camera, corners[k], corners[k | bit], model_colour(box.model_id));
    if (!box.label.empty()) draw_box_label(image, camera, corners, box.label, model_colour(box.model_id));
  }
  if (overlay.T_world_camera) {
    const auto& K = overlay.camera_intrinsics;
    const double d = overlay.frustum_depth_m;
    const Eigen::Vector3d centre = overlay.T_world_camera->translation();
    std::array<Eigen::Vector3d, 4> c;
    const std::array<Eigen::Vector2d, 4> px{Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(K.width - 0.5, -0.5),
                                            Eigen::Vector2d(K.width - 0.5, K.height - 0.5),
                                            Eigen::Vector2d(-0.5, K.height - 0.5)};
    for (int k = 0; k < 4; ++k)
      c[k] = *overlay.T_world_camera *
             Eigen::Vector3d((px[k].x() - K.cx) / K.fx * d, (px[k].y() - K.cy) / K.fy * d, d);
    for (int k = 0; k < 4; ++k) {
      draw_world_line(image, camera, centre, c[k], overlay.frustum_rgba8);
      draw_world_line(image, camera, c[k], c[(k + 1) % 4], overlay.frustum_rgba8);
    }
  }
  // Insets last but text, so lines never cross them.
  int left = 4;
  for (const auto& inset : overlay.insets) {
    if (inset.image.width <= 0 || inset.image.height <= 0) continue;
    const int h = std::min(overlay.inset_height_px, image.height - 16);
    if (h <= 0) break;
    const int w = std::max(1, inset.image.width * h / inset.image.height);
    const int top = image.height - h - 4;
    for (int y = -1; y <= h; ++y)
      for (int x = -1; x <= w; ++x) {
        if (!image.contains(left + x, top + y)) continue;
        const bool border = x < 0 || y < 0 || x == w || y == h;
        image.at(left + x, top + y) =
            border ? 0xFFFFFFFFu : inset.image.at(x * inset.image.width / w, y * inset.image.height / h);
      }
    draw_text(image, left, top - kLineHeightPx, inset.label, overlay.text_rgba8, 1);
    left += w + 8;
  }
  const int scale = std::max(1, overlay.text_scale);
  for (size_t i = 0; i < overlay.text_lines.size(); ++i)
    draw_text(image, 4 * scale, 4 * scale + static_cast<int>(i) * kLineHeightPx * scale, overlay.text_lines[i],
              overlay.text_rgba8, scale);
}

}  // namespace cofusion::renderer
