// SurfelPipelines::remove_region (shaders/surfel_remove_region.comp): against its CPU reference
// over edge sizes, and what it is for: taking a newly moving object out of the background model
// while the background it hid stays.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "common/error.h"
#include "kernels/preprocess.h"
#include "slam/surfel_model.h"
#include "slam/surfel_reference.h"
#include "support/gpu_fixture.h"
#include "moving_scene.h"

namespace cofusion::test {
namespace {
using kernels::Image;
namespace ref = slam::reference;
namespace L = gpu_layout;
using namespace moving_scene;

class SurfelRegion : public GpuTest {
 protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (!pipes_) {
      pre_ = std::make_unique<kernels::Preprocessor>(ctx());
      pipes_ = std::make_unique<slam::SurfelPipelines>(ctx(), *pre_);
    }
  }
  static void TearDownTestSuite() {
    pipes_.reset();
    pre_.reset();
    GpuTest::TearDownTestSuite();
  }
  // A live frame whose level-0 depth is `depth` exactly (no preprocessing: remove_region reads
  // only the level-0 depth and intrinsics).
  kernels::FramePyramid live_frame(const Intrinsics& k, const Image<float>& depth) {
    auto f = kernels::FramePyramid::allocate(ctx(), k, 1, "live");
    stream().upload(f.levels[0].depth_m, depth.pixels.data(), depth.bytes());
    return f;
  }
  static std::unique_ptr<kernels::Preprocessor> pre_;
  static std::unique_ptr<slam::SurfelPipelines> pipes_;
};
std::unique_ptr<kernels::Preprocessor> SurfelRegion::pre_;
std::unique_ptr<slam::SurfelPipelines> SurfelRegion::pipes_;

Surfel surfel_at(const Eigen::Vector3d& p, int i) {
  Surfel s{};
  s.px = float(p.x()), s.py = float(p.y()), s.pz = float(p.z());
  s.nz = -1.0f;
  s.confidence = 1.0f + float(i % 13);
  s.radius_m = 0.004f;
  s.colour_rgba8 = 0xFF000000u | uint32_t(i);
  s.created_frame = i % 50;
  s.last_seen_frame = 60;
  return s;
}

// Byte order: a total order for comparing kept surfels as sets (a surfel on a rounding boundary may
// be kept on one side only, which shifts every later one).
bool byte_less(const Surfel& a, const Surfel& b) { return std::memcmp(&a, &b, sizeof(Surfel)) < 0; }

size_t set_difference_size(std::vector<Surfel> a, std::vector<Surfel> b) {
  std::sort(a.begin(), a.end(), byte_less);
  std::sort(b.begin(), b.end(), byte_less);
  std::vector<Surfel> diff;
  std::set_symmetric_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(diff), byte_less);
  return diff.size();
}

// Tolerance: a surfel projecting onto a pixel boundary, or lying on the depth margin, may fall on
// either side in float: at most 0.2% of the surfels may differ between GPU and CPU.
TEST_F(SurfelRegion, RemoveRegionMatchesReference) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-0.1, 0.1), box(-3.0, 3.0), unit(0, 1);
  for (Size s : kEdgeSizes) {
    const Intrinsics k = intrinsics_for(s);
    // The model frame is not the camera frame; the model was built from another view.
    const auto T_world_model = pose(0.2, {0.1, 1, 0.3}, {0.1, 0.2, -0.1});
    const auto T_world_camera = pose(0.03, {1, 0.2, 0}, {0.02, 0.01, 0.0});
    const View live_view = render(room(), k, T_world_camera);
    Image<float> depth = live_view.depth_m;
    for (size_t i = 0; i < depth.size(); i += 17) depth.pixels[i] = 0.0f;  // holes remove nothing
    Image<uint32_t> labels = live_view.id;
    for (auto& l : labels.pixels) {
      const double u = unit(rng);
      if (u < 0.05) l = 7;
      else if (u < 0.1) l = 40;
    }
    const View model_view = render(room({0.12, 0.06, 1.62}), k, Eigen::Isometry3d::Identity());
    std::vector<Surfel> surfels;
    const Eigen::Isometry3d T_model_world = T_world_model.inverse();
    for (int y = 0; y < s.height; ++y)
      for (int x = 0; x < s.width; ++x) {
        const double z = model_view.depth_m.at(x, y) * (1.0 + jitter(rng));  // in front of / behind the surface
        const Eigen::Vector3d p((x - k.cx) / k.fx * z, (y - k.cy) / k.fy * z, z);
        surfels.push_back(surfel_at(T_model_world * p, int(surfels.size())));
      }
    for (int i = 0; i < 50; ++i)  // anywhere: behind the camera, outside the view
      surfels.push_back(surfel_at(Eigen::Vector3d(box(rng), box(rng), box(rng)), int(surfels.size())));

    const auto T_camera_model = T_world_camera.inverse() * T_world_model;
    for (uint32_t label : {1u, 7u}) {
      slam::SurfelModel model(ctx(), 3, 1024);
      model.upload(stream(), surfels);
      const auto live = live_frame(k, depth);
      const unsigned removed =
          pipes_->remove_region(stream(), model, live, T_camera_model, upload(labels.pixels, "labels"), label, 0.05f);
      EXPECT_EQ(removed + model.count(), surfels.size());
      L::RemoveRegionParams p{};
      slam::to_rows(T_camera_model, p.T_camera_model);
      p.fx = float(k.fx), p.fy = float(k.fy), p.cx = float(k.cx), p.cy = float(k.cy);
      p.width = uint32_t(k.width), p.height = uint32_t(k.height), p.surfel_count = uint32_t(surfels.size());
      p.label = label, p.margin_rel = 0.05f;
      const auto cpu = ref::remove_region(surfels, depth, labels.pixels, p);
      const auto gpu = model.download(stream());
      EXPECT_LE(set_difference_size(gpu, cpu), surfels.size() / 500) << name(s) << " label " << label;
      // The kept surfels stay in their order (surfel_at numbers them in the colour's low bits).
      EXPECT_TRUE(std::is_sorted(gpu.begin(), gpu.end(), [](const Surfel& a, const Surfel& b) {
        return (a.colour_rgba8 & 0xFFFFFFu) < (b.colour_rgba8 & 0xFFFFFFu);
      })) << name(s) << " label " << label;
      if (s.width >= 160) {
        EXPECT_GT(surfels.size() - cpu.size(), surfels.size() / 100) << "test data removes too little";
        EXPECT_GT(cpu.size(), surfels.size() / 2) << "test data removes too much";
      }
    }
  }
}

// A background model holding the wall behind the sphere (seen before the sphere arrived) and the
// sphere's surface. When the sphere starts moving, removing its labelled region takes every sphere
// surfel whose pixel has depth and leaves every wall surfel, including those behind the sphere.
TEST_F(SurfelRegion, RemovingAMovingObjectKeepsTheBackgroundItHid) {
  const Size s{160, 120};
  const Intrinsics k = intrinsics_for(s);
  const auto T_world_camera = pose(0.02, {0, 1, 0}, {0.01, 0.0, 0.0});
  Scene empty = room();
  empty.spheres.clear();
  const View wall = render(empty, k, T_world_camera);
  const View live = render(room(), k, T_world_camera);
  Image<float> depth = live.depth_m;
  size_t sphere_pixels_with_depth = 0, sphere_pixels = 0;
  for (size_t i = 0; i < depth.size(); ++i) {
    if (live.id.pixels[i] != 1) continue;
    ++sphere_pixels;
    if (i % 9 == 0) depth.pixels[i] = 0.0f;  // no reading: nothing is removed there
    sphere_pixels_with_depth += depth.pixels[i] > 0.0f;
  }
  ASSERT_GT(sphere_pixels, 1000u);
  std::vector<Surfel> surfels;  // model frame = world
  const auto add_view = [&](const View& v, uint32_t only_id) {
    for (int y = 0; y < s.height; ++y)
      for (int x = 0; x < s.width; ++x) {
        if (v.id.at(x, y) != only_id) continue;
        const double z = v.depth_m.at(x, y);
        surfels.push_back(surfel_at(T_world_camera * Eigen::Vector3d((x - k.cx) / k.fx * z, (y - k.cy) / k.fy * z, z),
                                    int(surfels.size())));
      }
  };
  add_view(wall, 0);
  const size_t wall_surfels = surfels.size();
  add_view(live, 1);

  slam::SurfelModel model(ctx(), 0, 1024);
  model.upload(stream(), surfels);
  const unsigned removed =
      pipes_->remove_region(stream(), model, live_frame(k, depth), T_world_camera.inverse(),
                            upload(live.id.pixels, "labels"), 1, 0.05f);
  EXPECT_EQ(removed, sphere_pixels_with_depth);
  EXPECT_EQ(model.count(), wall_surfels + (sphere_pixels - sphere_pixels_with_depth));
  const Eigen::Vector3d centre = room().spheres[0].centre;
  size_t wall_kept = 0;
  for (const auto& sf : model.download(stream()))
    wall_kept += (Eigen::Vector3d(sf.px, sf.py, sf.pz) - centre).norm() > 0.35;
  EXPECT_EQ(wall_kept, wall_surfels) << "the wall behind the sphere stays";

  // Nothing labelled 2: nothing goes.
  const unsigned before = model.count();
  EXPECT_EQ(pipes_->remove_region(stream(), model, live_frame(k, depth), T_world_camera.inverse(),
                                  upload(live.id.pixels, "labels"), 2, 0.05f),
            0u);
  EXPECT_EQ(model.count(), before);
}

TEST_F(SurfelRegion, RemoveRegionChecksItsInputs) {
  const Intrinsics k = intrinsics_for({37, 23});
  const auto live = live_frame(k, Image<float>(37, 23, 1.0f));
  slam::SurfelModel model(ctx(), 4, 1024);
  auto short_labels = gpu::Buffer::create(ctx(), 36 * 23 * 4, "short labels");
  try {
    pipes_->remove_region(stream(), model, live, Eigen::Isometry3d::Identity(), short_labels, 1, 0.05f);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("model 4"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("37x23"));
  }
  EXPECT_THROW(pipes_->remove_region(stream(), model, live, Eigen::Isometry3d::Identity(), nullptr, 1, 0.05f), Error);
  // An empty model has nothing to remove.
  auto labels = upload(Image<uint32_t>(37, 23, 1u).pixels, "labels");
  EXPECT_EQ(pipes_->remove_region(stream(), model, live, Eigen::Isometry3d::Identity(), labels, 1, 0.05f), 0u);
  EXPECT_EQ(model.count(), 0u);
}

}  // namespace
}  // namespace cofusion::test
