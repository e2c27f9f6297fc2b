// CPU overlays: lines, projected world lines, the bitmap font, PNG screenshots.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/error.h"
#include "renderer/overlay.h"
#include "renderer/scene_fixture.h"
#include "support/test_support.h"

namespace cofusion::test {
namespace {

using renderer::Image;
constexpr uint32_t kBlack = 0xFF000000u, kWhite = 0xFFFFFFFFu;

size_t count_colour(const Image& img, uint32_t c) {
  size_t n = 0;
  for (auto px : img.rgba) n += px == c;
  return n;
}

TEST(Overlay, LineCoversEndpointsAndClips) {
  Image img(20, 10, kBlack);
  renderer::draw_line(img, 2, 3, 12, 7, kWhite);
  EXPECT_EQ(img.at(2, 3), kWhite);
  EXPECT_EQ(img.at(12, 7), kWhite);
  EXPECT_EQ(count_colour(img, kWhite), 11u);  // one pixel per column of the major axis
  Image clipped(20, 10, kBlack);
  renderer::draw_line(clipped, -100, 5, 100, 5, kWhite);  // far outside both ends
  EXPECT_EQ(count_colour(clipped, kWhite), 20u);
}

TEST(Overlay, WorldLineProjectsAndClipsBehindCamera) {
  renderer::VirtualCamera cam;
  cam.intrinsics = {50, 50, 24.5, 24.5, 50, 50};
  Image img(50, 50, kBlack);
  // A vertical segment through the optical axis at 2 m: column cx.
  renderer::draw_world_line(img, cam, {0, -0.5, 2}, {0, 0.5, 2}, kWhite);
  EXPECT_EQ(img.at(25, 25), kWhite);  // lround(24.5) = 25
  EXPECT_EQ(img.at(20, 25), kBlack);
  // Entirely behind the camera: nothing.
  Image behind(50, 50, kBlack);
  renderer::draw_world_line(behind, cam, {-1, 0, -1}, {1, 0, -2}, kWhite);
  EXPECT_EQ(count_colour(behind, kWhite), 0u);
  // Crossing the near plane: only the part in front is drawn, not a mirrored copy.
  Image crossing(50, 50, kBlack);
  renderer::draw_world_line(crossing, cam, {0.2, 0, -1}, {0.2, 0, 3}, kWhite);
  for (int x = 0; x < 25; ++x)
    for (int y = 0; y < 50; ++y) EXPECT_EQ(crossing.at(x, y), kBlack) << x << "," << y;
  EXPECT_GT(count_colour(crossing, kWhite), 0u);
}

TEST(Overlay, FontGlyphsAndText) {
  // 'H': both outer columns full, middle row lit across.
  for (int row = 0; row < 7; ++row) {
    EXPECT_TRUE(renderer::glyph_pixel('H', 0, row));
    EXPECT_TRUE(renderer::glyph_pixel('H', 4, row));
  }
  for (int col = 0; col < 5; ++col) EXPECT_TRUE(renderer::glyph_pixel('H', col, 3));
  EXPECT_FALSE(renderer::glyph_pixel('H', 2, 0));
  for (int col = 0; col < 5; ++col)
    for (int row = 0; row < 7; ++row) EXPECT_FALSE(renderer::glyph_pixel(' ', col, row));
  EXPECT_TRUE(renderer::glyph_pixel('\x01', 1, 0));  // non-printable -> '?', whose top row is lit at column 1
  EXPECT_EQ(renderer::text_width_px("AB"), 11);
  EXPECT_EQ(renderer::text_width_px("AB", 2), 22);

  Image img(40, 12, 0xFF808080u);
  renderer::draw_text(img, 1, 1, "HI", kWhite, 1);
  EXPECT_EQ(img.at(1, 1), kWhite);          // H column 0, row 0
  EXPECT_EQ(img.at(1 + 6 + 2, 1), kWhite);  // I: column 2 is the stem
  EXPECT_EQ(img.at(3, 1), 0xFF808080u);     // H column 2 row 0 is empty (no shadow there either)
  EXPECT_EQ(img.at(2, 8), kBlack);          // shadow below H's column 0, one pixel down-right
}

TEST(Overlay, DrawsTrajectoryBoxesFrustumAndText) {
  const auto scene = test_scene();
  auto cam = test_camera(160, 120);
  renderer::Overlay overlay;
  for (int i = 0; i <= 10; ++i) overlay.trajectory_world.emplace_back(-0.5 + 0.1 * i, -0.2, 0.8);
  for (const auto& c : scene) overlay.boxes.push_back(renderer::bounding_box(c));
  overlay.T_world_camera = Eigen::Isometry3d(Eigen::Translation3d(0.5, -0.2, 0.8));
  overlay.camera_intrinsics = {525, 525, 319.5, 239.5, 640, 480};
  overlay.text_lines = {"FRAME 1"};
  const uint32_t bg = 0xFF102030u;
  Image img(160, 120, bg);
  renderer::draw_overlay(img, cam, overlay);
  EXPECT_GT(count_colour(img, overlay.trajectory_rgba8), 20u);
  EXPECT_GT(count_colour(img, renderer::model_colour(1)), 20u);
  EXPECT_GT(count_colour(img, renderer::model_colour(2)), 20u);
  EXPECT_GT(count_colour(img, overlay.frustum_rgba8), 20u);  // frustum plus text
  EXPECT_TRUE(renderer::bounding_box(SurfelCloud{}).bounds_model.isEmpty());
}

TEST(Overlay, BoxLabelShowsIdAndClassAboveTheBox) {
  EXPECT_EQ(renderer::model_label(3, "cup"), "3 cup");
  EXPECT_EQ(renderer::model_label(3, ""), "3");
  const auto scene = test_scene();
  const auto cam = test_camera(160, 120);
  const uint32_t bg = 0xFF102030u, colour = renderer::model_colour(1);
  renderer::Overlay overlay;
  overlay.boxes.push_back(renderer::bounding_box(scene[1]));
  EXPECT_TRUE(overlay.boxes[0].label.empty());  // bounding_box() gives none: the caller names it
  Image plain(160, 120, bg);
  renderer::draw_overlay(plain, cam, overlay);
  overlay.boxes[0].label = renderer::model_label(1, "ball");
  Image labelled(160, 120, bg);
  renderer::draw_overlay(labelled, cam, overlay);
  // The text adds pixels in the box's colour and its shadow, all above the box's lowest line.
  EXPECT_GT(count_colour(labelled, colour), count_colour(plain, colour) + 20);
  EXPECT_GT(count_colour(labelled, kBlack), 20u);
  EXPECT_EQ(count_colour(plain, kBlack), 0u);
  int lowest_box_row = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x)
      if (plain.at(x, y) == colour) lowest_box_row = y;
  int changed_below = 0;
  for (int y = lowest_box_row; y < 120; ++y)
    for (int x = 0; x < 160; ++x) changed_below += labelled.at(x, y) != plain.at(x, y);
  EXPECT_EQ(changed_below, 0);
}

TEST(Overlay, InsetsArePastedScaledAlongTheBottom) {
  Image view(320, 240, 0xFF000000u);
  Image inset(64, 48, 0xFF0000FFu);  // red
  inset.at(63, 47) = 0xFF00FF00u;    // green bottom-right pixel
  renderer::Overlay overlay;
  overlay.insets = {{inset, "rgb"}, {inset, "depth"}};
  overlay.inset_height_px = 96;
  renderer::draw_overlay(view, renderer::VirtualCamera{}, overlay);
  // First inset: 128x96 at x = 4, bottom at 240 - 4; scaled by 2.
  EXPECT_EQ(view.at(4 + 10, 240 - 4 - 96 + 10), 0xFF0000FFu);
  EXPECT_EQ(view.at(4 + 127, 240 - 4 - 1), 0xFF00FF00u);
  EXPECT_EQ(view.at(3, 240 - 4 - 50), 0xFFFFFFFFu) << "border";
  // Second inset starts after the first and a gap.
  EXPECT_EQ(view.at(4 + 128 + 8 + 10, 240 - 4 - 50), 0xFF0000FFu);
  EXPECT_EQ(view.at(300, 20), 0xFF000000u) << "nothing else drawn";
}

TEST(Screenshot, PngRoundTripAndEmptyImage) {
  Image img(7, 5, kBlack);
  img.at(3, 2) = renderer::rgba8(10, 200, 30);
  img.at(6, 4) = renderer::rgba8(255, 0, 128);
  const auto dir = fresh_temp_dir();
  const auto path = dir / "shot.png";
  write_png_file(img, path);
  const Image back = renderer::read_png(path);
  EXPECT_EQ(back.width, 7);
  EXPECT_EQ(back.height, 5);
  EXPECT_EQ(back.rgba, img.rgba);
  EXPECT_THROW(renderer::encode_png(Image{}), Error);
  EXPECT_THROW(renderer::read_png(dir / "absent.png"), Error);
}

}  // namespace
}  // namespace cofusion::test
