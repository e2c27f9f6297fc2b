// The compute splatting renderer against its CPU reference, and its semantics (occlusion, model
// labels, read-only model buffers, bad input).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "common/error.h"
#include "renderer/scene_fixture.h"
#include "support/gpu_fixture.h"

namespace cofusion::test {
namespace {

using renderer::ColourMode;
using renderer::Image;
using renderer::RenderParams;
using renderer::ViewRenderer;

class ViewRendererTest : public GpuTest {};

struct SizeCase {
  int width, height;
};

// Rounding differs between the device's float arithmetic and the CPU's: a pixel on a footprint
// border may go to a neighbouring surfel and shading may differ by a step or two (NVIDIA's driver:
// 3 in one channel of the 1x1 image). Allow 2 per channel everywhere but 1% of the pixels, and
// at least one pixel at any size.
constexpr int kChannelTolerance = 2;
constexpr double kMaxMismatchShare = 0.01;

size_t allowed_mismatches(const Image& image) {
  return std::max<size_t>(1, static_cast<size_t>(kMaxMismatchShare * static_cast<double>(image.rgba.size())));
}

TEST_F(ViewRendererTest, MatchesCpuReferenceAcrossSizes) {
  const auto scene = test_scene();
  ViewRenderer renderer(ctx());
  for (const SizeCase size : {SizeCase{1, 1}, SizeCase{37, 23}, SizeCase{160, 120}, SizeCase{640, 480}}) {
    SCOPED_TRACE(std::to_string(size.width) + "x" + std::to_string(size.height));
    const auto cam = test_camera(size.width, size.height);
    RenderParams params;
    const Image gpu = renderer.render(stream(), std::span<const SurfelCloud>(scene), cam, params);
    const Image cpu = renderer::render_reference(scene, cam, params);
    ASSERT_EQ(gpu.rgba.size(), cpu.rgba.size());
    EXPECT_LE(mismatch_count(gpu, cpu, kChannelTolerance), allowed_mismatches(cpu))
        << "first mismatch, GPU against CPU: " << first_mismatch(gpu, cpu, kChannelTolerance);
    // Not trivially equal: the scene covers part of the image, the background the rest.
    if (size.width >= 160) {
      size_t background = 0;
      for (auto px : cpu.rgba) background += px == params.background_rgba8;
      EXPECT_GT(background, cpu.rgba.size() / 20);
      EXPECT_LT(background, cpu.rgba.size() / 2);
    }
  }
}

TEST_F(ViewRendererTest, EveryColourModeMatchesCpuReference) {
  const auto scene = test_scene();
  ViewRenderer renderer(ctx());
  const auto cam = test_camera(160, 120);
  for (ColourMode mode : {ColourMode::Rgb, ColourMode::ModelLabel, ColourMode::Normal, ColourMode::Confidence}) {
    SCOPED_TRACE(renderer::to_string(mode));
    RenderParams params;
    params.colour_mode = mode;
    const Image gpu = renderer.render(stream(), std::span<const SurfelCloud>(scene), cam, params);
    const Image cpu = renderer::render_reference(scene, cam, params);
    EXPECT_LE(mismatch_share(gpu, cpu, kChannelTolerance), kMaxMismatchShare);
  }
}

TEST_F(ViewRendererTest, NearerModelOccludesAndLabelsUsePalette) {
  using renderer::rgba8;
  // Two facing patches on the optical axis: model 7 at 1 m in front of model 3 at 2 m.
  std::vector<SurfelCloud> scene(2);
  scene[0].model_id = 3;
  add_patch(scene[0].surfels, {0, 0, 2}, {1, 0, 0}, {0, 1, 0}, 2.0, 0.01, rgba8(255, 0, 0), rgba8(255, 0, 0));
  scene[1].model_id = 7;
  add_patch(scene[1].surfels, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, 0.2, 0.01, rgba8(0, 255, 0), rgba8(0, 255, 0));
  renderer::VirtualCamera cam;
  cam.intrinsics = {100, 100, 31.5, 23.5, 64, 48};
  RenderParams params;
  params.colour_mode = ColourMode::ModelLabel;
  params.ambient = 1.0f;  // unshaded: the palette colour exactly
  ViewRenderer renderer(ctx());
  const Image img = renderer.render(stream(), std::span<const SurfelCloud>(scene), cam, params);
  EXPECT_EQ(img.at(32, 24), renderer::model_colour(7));
  EXPECT_EQ(img.at(2, 2), renderer::model_colour(3));
  EXPECT_NE(renderer::model_colour(7), renderer::model_colour(3));
  // RGB mode, light along the normal: full colour.
  params.colour_mode = ColourMode::Rgb;
  params.ambient = 0.35f;
  const Image rgb = renderer.render(stream(), std::span<const SurfelCloud>(scene), cam, params);
  EXPECT_EQ(rgb.at(32, 24), rgba8(0, 255, 0));
  // Normal mode: normal (0, 0, 1) -> (127.5, 127.5, 255) -> (128, 128, 255).
  params.colour_mode = ColourMode::Normal;
  const Image normal = renderer.render(stream(), std::span<const SurfelCloud>(scene), cam, params);
  EXPECT_EQ(normal.at(32, 24), rgba8(128, 128, 255));
}

TEST_F(ViewRendererTest, ConfidenceFilterAndEmptyScene) {
  auto scene = test_scene();
  ViewRenderer renderer(ctx());
  const auto cam = test_camera(80, 60);
  RenderParams params;
  params.min_confidence = 1000.0f;  // hides everything
  const Image img = renderer.render(stream(), std::span<const SurfelCloud>(scene), cam, params);
  for (auto px : img.rgba) ASSERT_EQ(px, params.background_rgba8);
  const Image none = renderer.render(stream(), std::span<const renderer::ModelView>(), cam, RenderParams{});
  for (auto px : none.rgba) ASSERT_EQ(px, RenderParams{}.background_rgba8);
}

TEST_F(ViewRendererTest, LeavesModelBuffersUnchanged) {
  const auto scene = test_scene();
  std::vector<renderer::ModelView> models;
  for (const auto& c : scene) {
    renderer::ModelView m;
    m.surfels = gpu::Buffer::create(ctx(), c.surfels.size() * sizeof(Surfel), "test model");
    stream().upload(m.surfels, std::span<const Surfel>(c.surfels));
    m.count = static_cast<unsigned>(c.surfels.size());
    m.model_id = c.model_id;
    m.T_world_model = c.T_world_model;
    models.push_back(m);
  }
  ViewRenderer renderer(ctx());
  const auto cam = test_camera(160, 120);
  const Image from_buffers = renderer.render(stream(), std::span<const renderer::ModelView>(models), cam, RenderParams{});
  const Image from_clouds = renderer.render(stream(), std::span<const SurfelCloud>(scene), cam, RenderParams{});
  EXPECT_EQ(from_buffers.rgba, from_clouds.rgba);
  for (size_t k = 0; k < scene.size(); ++k) {
    const auto back = stream().download<Surfel>(models[k].surfels, scene[k].surfels.size());
    ASSERT_EQ(0, std::memcmp(back.data(), scene[k].surfels.data(), back.size() * sizeof(Surfel))) << "model " << k;
  }
}

TEST_F(ViewRendererTest, RejectsBadInput) {
  ViewRenderer renderer(ctx());
  auto cam = test_camera(64, 48);
  cam.intrinsics.fx = 0;
  const auto scene = test_scene();
  EXPECT_THROW(renderer.render(stream(), std::span<const SurfelCloud>(scene), cam, RenderParams{}), Error);
  EXPECT_THROW(renderer::render_reference(scene, cam, RenderParams{}), Error);
  cam = test_camera(64, 48);
  renderer::ModelView too_small;
  too_small.surfels = gpu::Buffer::create(ctx(), sizeof(Surfel), "one surfel");
  too_small.count = 2;
  EXPECT_THROW(renderer.render(stream(), std::span<const renderer::ModelView>(&too_small, 1), cam, RenderParams{}),
               Error);
  EXPECT_THROW(renderer::look_at({0, 0, 0}, {0, 0, 0}, {0, -1, 0}), Error);
  EXPECT_THROW(renderer::look_at({0, 0, 0}, {0, 1, 0}, {0, -1, 0}), Error);
}

TEST(LookAt, LooksAtTargetWithUpUp) {
  const auto T = renderer::look_at({1, -1, 0}, {0, 0, 2}, {0, -1, 0});
  const Eigen::Vector3d target_view = T.inverse() * Eigen::Vector3d(0, 0, 2);
  EXPECT_NEAR(target_view.x(), 0, 1e-12);
  EXPECT_NEAR(target_view.y(), 0, 1e-12);
  EXPECT_GT(target_view.z(), 0);
  EXPECT_LT((T.linear() * Eigen::Vector3d(0, 1, 0)).dot(Eigen::Vector3d(0, -1, 0)), 0);  // view y points down
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
}

}  // namespace
}  // namespace cofusion::test
