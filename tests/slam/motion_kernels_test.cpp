// Multi-model kernels of slam/motion_kernels.h: live-vertex masking and motion residuals against
// their CPU references over edge sizes, what they mean on an analytic scene with a moving sphere
// (masked tracking of the background, residuals small on the static part and large on the moved
// one), and their input checks.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <random>

#include "common/error.h"
#include "kernels/preprocess.h"
#include "kernels/preprocess_reference.h"
#include "slam/motion_kernels.h"
#include "slam/motion_reference.h"
#include "slam/surfel_model.h"
#include "slam/tracker.h"
#include "support/gpu_fixture.h"
#include "moving_scene.h"

namespace cofusion::test {
namespace {
using glm::vec4;
using kernels::Image;
namespace ref = slam::reference;
namespace L = gpu_layout;
using namespace moving_scene;

class MotionKernelsTest : public GpuTest {
 protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (!motion_) {
      motion_ = std::make_unique<slam::MotionKernels>(ctx());
      pre_ = std::make_unique<kernels::Preprocessor>(ctx());
    }
  }
  static void TearDownTestSuite() {
    motion_.reset();
    pre_.reset();
    GpuTest::TearDownTestSuite();
  }
  template <typename T>
  Image<T> download(const gpu::BufferPtr& b, int w, int h) {
    Image<T> out(w, h);
    out.pixels = stream().template download<T>(b, out.size());
    return out;
  }
  // A level with host maps uploaded (vertex, normal, intensity), as a predicted view or a live frame.
  kernels::FramePyramid::Level upload_level(const Intrinsics& k, const Image<vec4>& vertex, const Image<vec4>& normal,
                                            const Image<float>& intensity) {
    kernels::FramePyramid::Level l;
    l.width = k.width, l.height = k.height, l.intrinsics = k;
    l.vertex = upload(vertex.pixels, "vertex");
    l.normal = upload(normal.pixels, "normal");
    l.intensity = upload(intensity.pixels, "intensity");
    return l;
  }
  static std::unique_ptr<slam::MotionKernels> motion_;
  static std::unique_ptr<kernels::Preprocessor> pre_;
};
std::unique_ptr<slam::MotionKernels> MotionKernelsTest::motion_;
std::unique_ptr<kernels::Preprocessor> MotionKernelsTest::pre_;

// The float whose bits are 0x7F7F7F7F, which the GPU tests fill buffers with (stale content).
float stale_float() {
  const uint32_t bits = 0x7F7F7F7Fu;
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

size_t count_differing(const Image<vec4>& a, const Image<vec4>& b) {
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += a.pixels[i] != b.pixels[i];
  return n;
}

// ---- masking ---------------------------------------------------------------------------------

// Masking copies or zeroes whole pixels, so GPU and CPU must agree exactly, at every level.
TEST_F(MotionKernelsTest, MaskVerticesMatchesReferenceAtEveryLevel) {
  std::mt19937 rng(11);
  const uint32_t label_values[] = {0u, 1u, 2u, 5u, 31u, 32u, 255u, 0xFFFFFFFFu};
  std::uniform_int_distribution<int> pick(0, 7);
  std::uniform_real_distribution<float> coord(-2.0f, 3.0f), unit(0, 1);
  for (Size s : kEdgeSizes) {
    Image<uint32_t> labels(s.width, s.height);
    for (auto& l : labels.pixels) l = label_values[pick(rng)];
    auto label_buffer = upload(labels.pixels, "labels");
    int w = s.width, h = s.height;
    for (int level = 0; level < 4; ++level) {
      Image<vec4> src(w, h);
      for (auto& v : src.pixels) v = vec4(coord(rng), coord(rng), coord(rng), unit(rng) < 0.8f ? 1.0f : 0.0f);
      auto src_buffer = upload(src.pixels, "src vertex");
      auto dst_buffer = gpu::Buffer::create(ctx(), src.bytes(), "masked vertex");
      for (uint32_t keep : {0u, 1u, (1u << 2) | (1u << 31), 0xFFFFFFFFu}) {
        stream().run([&](gpu::CommandList& c) {
          c.fill(dst_buffer, 0x7F7F7F7Fu);  // stale content must be overwritten everywhere
          c.barrier();
          motion_->mask_vertices(c, src_buffer, dst_buffer, label_buffer, w, h, s.width, s.height, level, keep);
        });
        const auto cpu = ref::mask_vertices(src, labels, level, keep);
        EXPECT_EQ(count_differing(download<vec4>(dst_buffer, w, h), cpu), 0u)
            << name(s) << " level " << level << " keep " << std::hex << keep;
        // Restricted to a rectangle: the rest keeps its content.
        const PixelRect rect{w / 4, h / 2, w / 4 + (w + 2) / 3, h + 2};
        stream().run([&](gpu::CommandList& c) {
          c.fill(dst_buffer, 0x7F7F7F7Fu);
          c.barrier();
          motion_->mask_vertices(c, src_buffer, dst_buffer, label_buffer, w, h, s.width, s.height, level, keep, rect);
        });
        const auto cpu_rect = ref::mask_vertices(src, labels, level, keep, Image<vec4>(w, h, vec4(stale_float())), rect);
        EXPECT_EQ(count_differing(download<vec4>(dst_buffer, w, h), cpu_rect), 0u)
            << name(s) << " level " << level << " keep " << std::hex << keep << " in a rectangle";
        if (s.width == 160 && level == 0 && keep == ((1u << 2) | (1u << 31))) {
          size_t kept = 0;
          for (const auto& v : cpu.pixels) kept += v != vec4(0.0f);
          EXPECT_GT(kept, cpu.size() / 20) << "test labels keep too little";
          EXPECT_LT(kept, cpu.size() / 2) << "test labels keep too much";
        }
      }
      w = kernels::half_size(w), h = kernels::half_size(h);
    }
  }
}

TEST_F(MotionKernelsTest, MaskVerticesRejectsMismatchedSizesAndShortBuffers) {
  auto labels = gpu::Buffer::create(ctx(), 40 * 30 * 4, "labels");
  auto src = gpu::Buffer::create(ctx(), 20 * 15 * 16, "src");
  auto dst = gpu::Buffer::create(ctx(), 20 * 15 * 16, "dst");
  auto cmd = stream().begin();
  EXPECT_NO_THROW(motion_->mask_vertices(cmd, src, dst, labels, 20, 15, 40, 30, 1, 1u));
  EXPECT_THROW(motion_->mask_vertices(cmd, src, dst, labels, 20, 15, 40, 30, 0, 1u), Error);  // wrong level
  EXPECT_THROW(motion_->mask_vertices(cmd, src, dst, labels, 20, 15, 41, 30, 1, 1u), Error);  // labels too short
  EXPECT_THROW(motion_->mask_vertices(cmd, src, dst, labels, 40, 30, 40, 30, 0, 1u), Error);  // vertices too short
  EXPECT_THROW(motion_->mask_vertices(cmd, src, nullptr, labels, 20, 15, 40, 30, 1, 1u), Error);
  try {
    motion_->mask_vertices(cmd, src, dst, labels, 20, 16, 40, 30, 1, 1u);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("20x16"));
  }
  stream().submit(std::move(cmd));
}

// The pyramid helpers: masked levels share everything with the live levels but the vertex map,
// and mask_levels masks each level by the level-0 labels.
TEST_F(MotionKernelsTest, MaskLevelsMasksEveryLevelOfAFrame) {
  const Size s{160, 120};
  const Intrinsics k = intrinsics_for(s);
  const View view = render(room(), k, Eigen::Isometry3d::Identity());
  std::vector<uint8_t> rgb(size_t(s.width) * s.height * 3, 100);
  auto frame = kernels::FramePyramid::allocate(ctx(), k, 4, "live");
  frame.upload(stream(), view.depth_m.pixels.data(), rgb.data());
  stream().run([&](gpu::CommandList& c) {
    pre_->record_frame(c, frame, kernels::FramePyramid::kUploadMetresPerUnit, kernels::PreprocessParams{});
  });
  auto masked = slam::MotionKernels::allocate_masked_levels(ctx(), frame.levels, "sphere");
  ASSERT_EQ(masked.size(), frame.levels.size());
  auto labels = upload(view.id.pixels, "labels");  // 0 background, 1 sphere, no hits none
  stream().run([&](gpu::CommandList& c) { motion_->mask_levels(c, frame.levels, masked, labels, 1u << 1); });
  for (size_t l = 0; l < masked.size(); ++l) {
    EXPECT_NE(masked[l].vertex, frame.levels[l].vertex);
    EXPECT_EQ(masked[l].normal, frame.levels[l].normal);
    EXPECT_EQ(masked[l].intensity, frame.levels[l].intensity);
    const int w = frame.levels[l].width, h = frame.levels[l].height;
    const auto live = download<vec4>(frame.levels[l].vertex, w, h);
    const auto gpu = download<vec4>(masked[l].vertex, w, h);
    EXPECT_EQ(count_differing(gpu, ref::mask_vertices(live, view.id, int(l), 1u << 1)), 0u) << "level " << l;
    size_t kept = 0, valid = 0;
    for (size_t i = 0; i < gpu.size(); ++i) kept += gpu.pixels[i].w > 0, valid += live.pixels[i].w > 0;
    EXPECT_GT(kept, 0u) << "level " << l;
    EXPECT_LT(kept, valid / 2) << "level " << l << ": the sphere covers less than half the view";
  }
  EXPECT_THROW(
      {
        auto c = stream().begin();
        motion_->mask_levels(c, frame.levels, frame.levels, labels, 1u);  // in place
      },
      Error);
}

// Co-Fusion tracks each model with its own points only: with the sphere moving by 8 cm and the
// camera by a few centimetres, tracking the background's points alone recovers the camera motion.
TEST_F(MotionKernelsTest, MaskedBackgroundTracksTheCameraWhileTheObjectMoves) {
  const Size s{160, 120};
  const Intrinsics k = intrinsics_for(s);
  const Eigen::Vector3d c0(0.15, 0.05, 1.6), c1 = c0 + Eigen::Vector3d(-0.06, 0.02, -0.05);
  const auto T_world_live = pose(0.02, {0.3, 1, 0.2}, {0.02, -0.01, 0.015});
  const View reference_view = render(room(c0), k, Eigen::Isometry3d::Identity());
  const View live_view = render(room(c1), k, T_world_live);
  const auto make_frame = [&](const View& v) {
    std::vector<uint8_t> rgb(v.intensity.size() * 3);
    for (size_t i = 0; i < v.intensity.size(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = uint8_t(v.intensity.pixels[i]);
    auto f = kernels::FramePyramid::allocate(ctx(), k, 3, "frame");
    f.upload(stream(), v.depth_m.pixels.data(), rgb.data());
    kernels::PreprocessParams params;
    params.live_gradients = true;  // the reference frame stands in for a model prediction
    stream().run([&](gpu::CommandList& c) { pre_->record_frame(c, f, kernels::FramePyramid::kUploadMetresPerUnit, params); });
    return f;
  };
  const auto reference = make_frame(reference_view), live = make_frame(live_view);
  auto masked = slam::MotionKernels::allocate_masked_levels(ctx(), live.levels, "background");
  auto labels = upload(live_view.id.pixels, "labels");
  stream().run([&](gpu::CommandList& c) { motion_->mask_levels(c, live.levels, masked, labels, 1u << 0); });
  slam::TrackerParams params;
  params.iterations_per_level = {10, 5, 4};
  slam::Tracker tracker(ctx(), params);
  const auto result = tracker.track(stream(), masked, reference.levels, Eigen::Isometry3d::Identity());
  ASSERT_FALSE(result.failed) << result.failure_reason;
  const Eigen::Isometry3d error = T_world_live.inverse() * result.T_reference_live;
  EXPECT_LT(error.translation().norm(), 0.003);
  EXPECT_LT(Eigen::AngleAxisd(error.rotation()).angle(), 0.3 * M_PI / 180);
}

// ---- motion residuals ------------------------------------------------------------------------

struct HostMaps {
  Image<vec4> vertex, normal;
  Image<float> intensity;
};
HostMaps maps_of(const View& view, const Intrinsics& k) {
  HostMaps m;
  kernels::reference::vertex_normal_map(view.depth_m, k, m.vertex, m.normal);
  m.intensity = view.intensity;
  return m;
}

L::MotionResidualParams residual_params(const Intrinsics& k, const Eigen::Isometry3d& T_reference_live) {
  L::MotionResidualParams p{};
  slam::to_rows(T_reference_live, p.T_reference_live);
  p.fx = float(k.fx), p.fy = float(k.fy), p.cx = float(k.cx), p.cy = float(k.cy);
  p.width = uint32_t(k.width), p.height = uint32_t(k.height);
  p.rect_x1 = p.width, p.rect_y1 = p.height;
  p.live_intensity_gain = 1.0f;
  return p;
}


// Tolerance: 1e-5 m / 1e-5 relative on the distances and 1e-5 on intensities (a handful of float
// operations, FMA contraction may differ); a projection on a pixel boundary may pick another
// reference pixel on one side, which may change a pixel's values or status: at most 0.2% of pixels.
TEST_F(MotionKernelsTest, ResidualsMatchReference) {
  int seen[3] = {0, 0, 0};  // statuses 0, 1, -1 at the larger sizes
  for (Size s : kEdgeSizes) {
    const Intrinsics k = intrinsics_for(s);
    const View reference_view = render(room({0.1, 0.0, 1.5}), k, Eigen::Isometry3d::Identity());
    // A small camera motion, and a large one that puts much of the live frame outside the
    // reference view or behind its camera.
    for (const auto& T_world_live : {pose(0.03, {0.3, 1, 0.2}, {0.03, -0.02, 0.02}), pose(2.2, {0, 1, 0.1}, {0.5, 0, 1.5})}) {
      View live_view = render(room({0.16, 0.03, 1.45}), k, T_world_live);
      for (size_t i = 0; i < live_view.depth_m.size(); i += 13) live_view.depth_m.pixels[i] = 0.0f;  // holes
      const HostMaps live = maps_of(live_view, k);
      HostMaps reference = maps_of(reference_view, k);
      for (size_t i = 0; i < reference.normal.size(); i += 7) reference.normal.pixels[i].w = 0.0f;  // point-to-point
      for (size_t i = 3; i < reference.vertex.size(); i += 11) reference.vertex.pixels[i] = vec4(0.0f);
      auto out = gpu::Buffer::create(ctx(), live.vertex.bytes(), "residuals");
      const auto lv = upload(live.vertex.pixels), li = upload(live.intensity.pixels);
      const auto rv = upload(reference.vertex.pixels), rn = upload(reference.normal.pixels);
      const auto ri = upload(reference.intensity.pixels);
      // The whole frame, then a model's rectangle (the rest must keep its stale content) and one
      // reaching past the image.
      for (const PixelRect rect : {PixelRect::full(s.width, s.height),
                                   PixelRect{s.width / 3, s.height / 4, s.width / 3 + (s.width + 1) / 2, s.height},
                                   PixelRect{s.width - 1, s.height / 2, s.width + 40, s.height + 3}}) {
        auto p = residual_params(k, T_world_live);  // reference camera = world
        p.rect_x0 = uint32_t(rect.x0), p.rect_y0 = uint32_t(rect.y0), p.rect_x1 = uint32_t(rect.x1),
        p.rect_y1 = uint32_t(rect.y1);
        // An exposure gain on the partial rectangles (the live intensity scaled before comparing).
        if (rect != PixelRect::full(s.width, s.height)) p.live_intensity_gain = 1.15f;
        stream().run([&](gpu::CommandList& c) {
          c.fill(out, 0x7F7F7F7Fu);
          c.barrier();
          motion_->residuals(c, lv, li, rv, rn, ri, out, p);
        });
        const auto gpu = download<vec4>(out, s.width, s.height);
        const auto cpu = ref::motion_residuals(live.vertex, live.intensity, reference.vertex, reference.normal,
                                               reference.intensity, p, Image<vec4>(s.width, s.height, vec4(stale_float())));
        const PixelRect inside = rect.clamped(s.width, s.height);
        size_t bad = 0, stale = 0;
        for (size_t i = 0; i < cpu.size(); ++i) {
          const vec4 g = gpu.pixels[i], c = cpu.pixels[i];
          const auto near = [](float a, float b) { return std::abs(a - b) <= 1e-5f + 1e-5f * std::abs(b); };
          bad += !(g.w == c.w && near(g.x, c.x) && near(g.y, c.y) && near(g.z, c.z));
          stale += c == vec4(stale_float());
          if (s.width >= 160 && rect == PixelRect::full(s.width, s.height)) ++seen[c.w == 0.0f ? 0 : c.w == 1.0f ? 1 : 2];
        }
        EXPECT_LE(bad, cpu.size() / 500) << name(s) << " rect x " << rect.x0 << ".." << rect.x1;
        EXPECT_EQ(stale, cpu.size() - size_t(inside.area())) << name(s) << " rect x " << rect.x0 << ".." << rect.x1;
      }
    }
  }
  EXPECT_GT(seen[0], 1000) << "no live holes exercised";
  EXPECT_GT(seen[1], 10000) << "too few associations exercised";
  EXPECT_GT(seen[2], 10000) << "too few unassociated live points exercised";
}

// A frame against itself at the identity: every valid live pixel associates with itself and costs
// nothing; live holes say 0, reference holes -1; unused components are 0.
TEST_F(MotionKernelsTest, ResidualsOfAFrameAgainstItselfAreZero) {
  const Size s{37, 23};
  const Intrinsics k = intrinsics_for(s);
  View view = render(room(), k, Eigen::Isometry3d::Identity());
  for (int y = 0; y < s.height; ++y) view.depth_m.at(5, y) = 0.0f;  // a live (and reference) hole
  const HostMaps maps = maps_of(view, k);
  HostMaps reference = maps;
  for (int y = 0; y < s.height; ++y) reference.vertex.at(20, y) = vec4(0.0f);  // the model lacks a column
  const auto live_level = upload_level(k, maps.vertex, maps.normal, maps.intensity);
  const auto reference_level = upload_level(k, reference.vertex, reference.normal, reference.intensity);
  auto out = gpu::Buffer::create(ctx(), maps.vertex.bytes(), "residuals");
  stream().run([&](gpu::CommandList& c) { motion_->residuals(c, live_level, reference_level, Eigen::Isometry3d::Identity(), out); });
  const auto r = download<vec4>(out, s.width, s.height);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x) {
      const vec4 v = r.at(x, y);
      const float expected = maps.vertex.at(x, y).w == 0.0f ? 0.0f : x == 20 ? -1.0f : 1.0f;
      ASSERT_EQ(v.w, expected) << x << "," << y;
      EXPECT_LT(std::abs(v.x) + std::abs(v.y) + std::abs(v.z), 1e-6f) << x << "," << y;
    }
}

// What the segmentation's unaries see: after the camera motion is known, the static background
// costs (almost) nothing and the sphere, moved 12 cm towards the camera, costs centimetres, with
// the live surface in front of the predicted one (negative signed depth difference).
TEST_F(MotionKernelsTest, ResidualsSeparateTheMovedObjectFromTheStaticBackground) {
  const Size s{160, 120};
  const Intrinsics k = intrinsics_for(s);
  const Eigen::Vector3d c0(0.15, 0.05, 1.6), c1 = c0 + Eigen::Vector3d(0.04, 0.0, -0.12);
  const auto T_world_live = pose(0.03, {0.3, 1, 0.2}, {0.03, -0.02, 0.02});
  const HostMaps reference = maps_of(render(room(c0), k, Eigen::Isometry3d::Identity()), k);
  const View live_view = render(room(c1), k, T_world_live);
  const HostMaps live = maps_of(live_view, k);
  auto out = gpu::Buffer::create(ctx(), live.vertex.bytes(), "residuals");
  const auto live_level = upload_level(k, live.vertex, live.normal, live.intensity);
  const auto reference_level = upload_level(k, reference.vertex, reference.normal, reference.intensity);
  stream().run([&](gpu::CommandList& c) { motion_->residuals(c, live_level, reference_level, T_world_live, out); });
  const auto r = download<vec4>(out, s.width, s.height);
  std::vector<float> background, sphere, sphere_depth;
  for (size_t i = 0; i < r.size(); ++i) {
    if (r.pixels[i].w != 1.0f) continue;
    EXPECT_GE(r.pixels[i].z, 0.0f);
    EXPECT_LE(r.pixels[i].z, 1.0f);
    (live_view.id.pixels[i] == 0 ? background : sphere).push_back(r.pixels[i].x);
    if (live_view.id.pixels[i] == 1) sphere_depth.push_back(r.pixels[i].y);
  }
  ASSERT_GT(background.size(), r.size() / 2);
  ASSERT_GT(sphere.size(), r.size() / 20);
  const auto quantile = [](std::vector<float> v, double q) {
    std::nth_element(v.begin(), v.begin() + long(q * double(v.size() - 1)), v.end());
    return v[size_t(q * double(v.size() - 1))];
  };
  // Background pixels that the sphere hid in the reference view associate with the sphere there.
  EXPECT_LT(quantile(background, 0.5), 0.001f);
  EXPECT_LT(quantile(background, 0.9), 0.005f);
  EXPECT_GT(quantile(sphere, 0.5), 0.05f);
  EXPECT_LT(quantile(sphere_depth, 0.9), -0.03f) << "the moved sphere is in front of its prediction";
}

TEST_F(MotionKernelsTest, ResidualsRejectMismatchedLevels) {
  const Intrinsics k = intrinsics_for({37, 23}), k2 = intrinsics_for({36, 23});
  const Image<vec4> v(37, 23), v2(36, 23);
  const Image<float> in(37, 23), in2(36, 23);
  const auto a = upload_level(k, v, v, in), b = upload_level(k2, v2, v2, in2);
  auto out = gpu::Buffer::create(ctx(), v.bytes(), "residuals");
  auto cmd = stream().begin();
  EXPECT_THROW(motion_->residuals(cmd, a, b, Eigen::Isometry3d::Identity(), out), Error);
  auto short_out = gpu::Buffer::create(ctx(), 16, "short");
  EXPECT_THROW(motion_->residuals(cmd, a, a, Eigen::Isometry3d::Identity(), short_out), Error);
  auto missing = a;
  missing.normal = nullptr;
  EXPECT_THROW(motion_->residuals(cmd, a, missing, Eigen::Isometry3d::Identity(), out), Error);
  Eigen::Isometry3d nan = Eigen::Isometry3d::Identity();
  nan.translation().x() = std::nan("");
  EXPECT_THROW(motion_->residuals(cmd, a, a, nan, out), Error);
  stream().submit(std::move(cmd));
}

}  // namespace
}  // namespace cofusion::test
