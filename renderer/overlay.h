#pragma once
// What the viewer draws over the splatted models, on the CPU into the downloaded image: the
// camera trajectory (polyline), model bounding boxes, the tracked camera's frustum, and text
// (status line, key help) in a built-in 5x7 bitmap font. Lines ignore depth (always on top).
#include <Eigen/Geometry>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/intrinsics.h"
#include "common/surfel_cloud.h"
#include "renderer/image.h"
#include "renderer/view_renderer.h"

namespace cofusion::renderer {

// Axis-aligned box in a model's frame, with that model's pose and id (for its colour).
struct ModelBox {
  int model_id = 0;
  Eigen::Isometry3d T_world_model = Eigen::Isometry3d::Identity();
  Eigen::AlignedBox3d bounds_model;  // empty boxes are not drawn
  // Drawn in the box's colour above its highest corner in the view, e.g. "3 cup"; empty = none.
  std::string label;
};
// The bounding box of a cloud's surfel centres (empty when it has none), without a label.
ModelBox bounding_box(const SurfelCloud& cloud);
// A box's label: the model id and, when known, its class ("3 cup", or "3").
std::string model_label(int model_id, const std::string& class_name);

// A small picture pasted along the bottom edge of the view (the live RGB, depth, segmentation),
// scaled by nearest neighbour to Overlay::inset_height_px, with a label above it.
struct Inset {
  Image image;
  std::string label;
};

struct Overlay {
  std::vector<Eigen::Vector3d> trajectory_world;  // camera positions, oldest first
  uint32_t trajectory_rgba8 = 0xFF00E0FFu;        // yellow
  std::vector<ModelBox> boxes;
  // The tracked camera: its frustum is drawn from its centre to its image corners at frustum_depth_m.
  std::optional<Eigen::Isometry3d> T_world_camera;
  Intrinsics camera_intrinsics;
  double frustum_depth_m = 0.15;
  uint32_t frustum_rgba8 = 0xFFFFFFFFu;
  std::vector<std::string> text_lines;  // drawn from the top-left, one per line
  uint32_t text_rgba8 = 0xFFFFFFFFu;
  int text_scale = 1;                   // pixels per font pixel
  std::vector<Inset> insets;            // left to right along the bottom edge
  int inset_height_px = 120;
};

// Draws every part of `overlay` seen by `camera` into `image` (the image of that camera).
void draw_overlay(Image& image, const VirtualCamera& camera, const Overlay& overlay);

// A 2D line, pixel centres at integer coordinates, clipped to the image (Bresenham).
void draw_line(Image& image, int x0, int y0, int x1, int y1, uint32_t rgba8);
// A 3D segment in the world, clipped at the camera's near plane (near_m) and projected.
void draw_world_line(Image& image, const VirtualCamera& camera, const Eigen::Vector3d& a_world,
                     const Eigen::Vector3d& b_world, uint32_t rgba8, double near_m = 0.01);

// Text in the 5x7 font; each glyph is 6x8 font pixels including spacing, times `scale`.
// Characters outside printable ASCII draw as '?'. A dark shadow keeps it readable on any background.
void draw_text(Image& image, int x, int y, std::string_view text, uint32_t rgba8, int scale = 1);
int text_width_px(std::string_view text, int scale = 1);
constexpr int kGlyphAdvancePx = 6;
constexpr int kLineHeightPx = 9;
// True where glyph `c` has a lit pixel at column col (0..4), row row (0..6).
bool glyph_pixel(char c, int col, int row);

}  // namespace cofusion::renderer
