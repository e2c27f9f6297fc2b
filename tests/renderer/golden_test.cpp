// Golden-image test of the offscreen renderer: the fixed test scene in all four colour modes
// (160x120 tiles of one 320x240 image, with trajectory, boxes, frustum and text drawn over the
// RGB tile), compared per pixel with tests/renderer/golden/scene_modes.png.
//
// On a mismatch the actual image and an amplified difference image are written to the test's
// temporary folder and their paths printed. To (re)generate the golden after an intended change,
// run the test with COFUSION_UPDATE_GOLDEN=1 in the environment, e.g.
//   COFUSION_UPDATE_GOLDEN=1 ./build/tests/cofusion_renderer_tests --gtest_filter='Golden*'
// then look at the new PNG before committing it.
#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>

#include "renderer/overlay.h"
#include "renderer/scene_fixture.h"
#include "support/gpu_fixture.h"
#include "support/test_support.h"

namespace cofusion::test {
namespace {

using renderer::ColourMode;
using renderer::Image;

class GoldenTest : public GpuTest {};

// Different devices round differently (and lavapipe versions may change): a pixel passes within
// 12 per channel, and up to 0.5% of the pixels may fail (footprint borders).
constexpr int kChannelTolerance = 12;
constexpr double kMaxMismatchShare = 0.005;

Image render_modes(gpu::Context& ctx, gpu::Stream& stream) {
  const auto scene = test_scene();
  const auto cam = test_camera(160, 120);
  renderer::ViewRenderer view(ctx);
  Image out(320, 240);
  const ColourMode modes[4] = {ColourMode::Rgb, ColourMode::ModelLabel, ColourMode::Normal, ColourMode::Confidence};
  for (int k = 0; k < 4; ++k) {
    renderer::RenderParams params;
    params.colour_mode = modes[k];
    Image tile = view.render(stream, std::span<const SurfelCloud>(scene), cam, params);
    renderer::Overlay overlay;
    if (k == 0) {
      for (int i = 0; i <= 20; ++i) {
        const double a = 0.08 * i;
        overlay.trajectory_world.emplace_back(0.6 * std::cos(a) - 0.2, -0.35, 1.4 - 0.6 * std::sin(a) - 0.2);
      }
      for (const auto& c : scene) overlay.boxes.push_back(renderer::bounding_box(c));
      overlay.T_world_camera = renderer::look_at(overlay.trajectory_world.back(), {-0.2, 0.05, 1.4}, {0, -1, 0});
      overlay.camera_intrinsics = {525, 525, 319.5, 239.5, 640, 480};
    }
    overlay.text_lines = {std::string("MODE ") + renderer::to_string(modes[k])};
    renderer::draw_overlay(tile, cam, overlay);
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 160; ++x) out.at((k % 2) * 160 + x, (k / 2) * 120 + y) = tile.at(x, y);
  }
  return out;
}

TEST_F(GoldenTest, SceneInAllColourModes) {
  const Image actual = render_modes(ctx(), stream());
  const auto golden_path = source_dir() / "tests" / "renderer" / "golden" / "scene_modes.png";
  const char* update = std::getenv("COFUSION_UPDATE_GOLDEN");
  if (update && std::string(update) == "1") {
    write_png_file(actual, golden_path);
    std::cout << "golden written: " << golden_path << "\n";
    return;
  }
  ASSERT_TRUE(std::filesystem::exists(golden_path))
      << golden_path << " is missing: run with COFUSION_UPDATE_GOLDEN=1 to create it";
  const Image golden = renderer::read_png(golden_path);
  ASSERT_EQ(golden.width, actual.width);
  ASSERT_EQ(golden.height, actual.height);
  const double share = mismatch_share(actual, golden, kChannelTolerance);
  if (share > kMaxMismatchShare) {
    const auto dir = fresh_temp_dir();
    Image diff(actual.width, actual.height);
    for (size_t i = 0; i < diff.rgba.size(); ++i) {
      uint32_t px = 0xFF000000u;
      for (int c = 0; c < 24; c += 8) {
        const int d = std::abs(static_cast<int>((actual.rgba[i] >> c) & 0xFF) - static_cast<int>((golden.rgba[i] >> c) & 0xFF));
        px |= static_cast<uint32_t>(std::min(255, d * 8)) << c;
      }
      diff.rgba[i] = px;
    }
    write_png_file(actual, dir / "actual.png");
    write_png_file(diff, dir / "diff.png");
    ADD_FAILURE() << "rendered image differs from " << golden_path << " in " << share * 100
                  << "% of the pixels (tolerance " << kChannelTolerance << " per channel); actual: "
                  << (dir / "actual.png") << ", difference x8: " << (dir / "diff.png");
  }
}

}  // namespace
}  // namespace cofusion::test
