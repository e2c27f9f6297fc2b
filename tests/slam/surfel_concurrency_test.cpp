// Thread safety of SurfelPipelines (surfel_model.h): one instance serves two threads that predict,
// fuse and cut regions from two different models on two streams at the same time, sharing one live
// frame and one label map; the results equal (exactly, surfel by surfel) those of the same work done one
// model after the other.
// Vulkan validation (its thread-safety checks included) runs throughout.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <glm/vec4.hpp>
#include <thread>
#include <tuple>

#include "kernels/preprocess.h"
#include "slam/surfel_model.h"
#include "support/gpu_fixture.h"
#include "moving_scene.h"

namespace cofusion::test {
namespace {
using kernels::Image;
using namespace moving_scene;

// Positions where two surfel lists differ (bytewise), and the difference in length.
size_t differing_surfels(const std::vector<Surfel>& a, const std::vector<Surfel>& b) {
  size_t differ = a.size() > b.size() ? a.size() - b.size() : b.size() - a.size();
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) differ += std::memcmp(&a[i], &b[i], sizeof(Surfel)) != 0;
  return differ;
}

struct Outcome {
  std::vector<Surfel> surfels;  // in the model's order
  std::vector<glm::vec4> predicted_vertex;
  slam::FusionStats stats;
  unsigned removed = 0;
};

class SurfelConcurrency : public GpuTest {};

TEST_F(SurfelConcurrency, TwoModelsOnTwoThreadsMatchSequentialWork) {
  const Size s{160, 120};
  const Intrinsics k = intrinsics_for(s);
  kernels::Preprocessor pre(ctx());
  const slam::SurfelPipelines pipes(ctx(), pre);

  // The shared live frame and label map (read by both threads).
  const View view = render(room(), k, Eigen::Isometry3d::Identity());
  std::vector<uint8_t> rgb(view.intensity.size() * 3);
  for (size_t i = 0; i < view.intensity.size(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = uint8_t(view.intensity.pixels[i]);
  auto live = kernels::FramePyramid::allocate(ctx(), k, 3, "live");
  live.upload(stream(), view.depth_m.pixels.data(), rgb.data());
  stream().run([&](gpu::CommandList& c) {
    pre.record_frame(c, live, kernels::FramePyramid::kUploadMetresPerUnit, kernels::PreprocessParams{});
  });
  auto labels = gpu::Buffer::create(ctx(), view.id.bytes(), "labels");
  stream().upload(labels, view.id.pixels.data(), view.id.bytes());

  // Each model starts from the frame fused from empty at its own pose (new surfels in pixel order:
  // splatting breaks exact depth ties by surfel index, so only a fixed order gives exactly
  // repeatable results).
  const auto T_camera_model = [](int id) { return pose(0.05 * id, {0.2, 1, 0.1}, {0.05 * id, -0.02, 0.03}); };
  const slam::FusionParams fusion;
  std::vector<Surfel> initial[3];
  for (int id : {1, 2}) {
    slam::SurfelModel model(ctx(), id, 1024);
    pipes.fuse(stream(), model, live, T_camera_model(id), 0, fusion);
    initial[id] = model.download(stream());
  }

  // Each model's work: predict it, fuse the pixels labelled as its slot, cut the sphere's region.
  const auto work = [&](gpu::Stream& stream, int id) {
    slam::SurfelModel model(ctx(), id, 1024);
    model.upload(stream, initial[id]);
    Outcome out;
    auto prediction = slam::ModelPrediction::allocate(ctx(), k, 3, "prediction " + std::to_string(id));
    stream.run([&](gpu::CommandList& c) { pipes.predict(c, model, T_camera_model(id), prediction, slam::PredictionParams{}, 1); });
    out.predicted_vertex = stream.download<glm::vec4>(prediction.levels[0].vertex, view.depth_m.size());
    out.stats = pipes.fuse(stream, model, live, T_camera_model(id), 1, fusion, labels, uint32_t(id % 2));
    out.removed = pipes.remove_region(stream, model, live, T_camera_model(id), labels, 1, 0.05f);
    out.surfels = model.download(stream);
    return out;
  };

  gpu::Stream second(ctx(), 1, "second stream");
  const Outcome sequential_a = work(stream(), 1), sequential_b = work(second, 2);
  ASSERT_GT(sequential_a.removed, 0u);
  ASSERT_GT(sequential_a.surfels.size(), 1000u);
  for (int round = 0; round < 3; ++round) {
    Outcome a, b;
    std::thread other([&] { b = work(second, 2); });
    a = work(stream(), 1);
    other.join();
    for (const auto& [got, expected, which] : {std::tuple{&a, &sequential_a, "model 1"}, std::tuple{&b, &sequential_b, "model 2"}}) {
      EXPECT_EQ(differing_surfels(got->surfels, expected->surfels), 0u) << which << " round " << round;
      size_t vertices_differ = 0;
      for (size_t i = 0; i < got->predicted_vertex.size(); ++i)
        vertices_differ += got->predicted_vertex[i] != expected->predicted_vertex[i];
      EXPECT_EQ(vertices_differ, 0u) << which << " round " << round;
      EXPECT_EQ(got->stats.surfels_after_fusion, expected->stats.surfels_after_fusion) << which;
      EXPECT_EQ(got->stats.surfels_after_cleanup, expected->stats.surfels_after_cleanup) << which;
      EXPECT_EQ(got->removed, expected->removed) << which;
    }
  }
}

}  // namespace
}  // namespace cofusion::test
