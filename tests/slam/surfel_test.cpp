// Surfel kernels (splat, resolve, subsample, associate, update, merge, cleanup) against their CPU
// references over edge sizes, and the model's fusion/prediction behaviour end to end.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <random>

#include "eval/surfel_map_metrics.h"
#include "kernels/preprocess_reference.h"
#include "slam/surfel_model.h"
#include "slam/surfel_reference.h"
#include "support/gpu_fixture.h"

namespace cofusion::test {
namespace {
using kernels::Image;
namespace ref = slam::reference;
namespace L = gpu_layout;

struct Size {
  int width, height;
};
const Size kSizes[] = {{1, 1}, {37, 23}, {160, 120}, {640, 480}};
std::string name(Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

Intrinsics intrinsics_for(Size s) {
  Intrinsics k;
  k.width = s.width, k.height = s.height;
  k.fx = k.fy = 525.0 * s.width / 640.0 + 1.0;
  k.cx = (s.width - 1) / 2.0 + 0.25;
  k.cy = (s.height - 1) / 2.0 - 0.25;
  return k;
}

// Depth of a scene seen by the camera: a back wall, a slanted floor and a sphere.
Image<float> scene_depth(Size s, const Intrinsics& k) {
  Image<float> d(s.width, s.height);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x) {
      const double rx = (x - k.cx) / k.fx, ry = (y - k.cy) / k.fy;
      double z = 2.5;
      if (ry > 0.1) z = std::min(z, 0.9 / ry);
      const double sx = 0.2, sy = 0.0, sz = 1.5, r = 0.3;
      const double b = rx * sx + ry * sy + sz, a = rx * rx + ry * ry + 1, c = sx * sx + sy * sy + sz * sz - r * r;
      if (b * b - a * c > 0) z = std::min(z, (b - std::sqrt(b * b - a * c)) / a);
      d.at(x, y) = float(z);
    }
  return d;
}

Eigen::Isometry3d test_pose(double angle = 0.03, Eigen::Vector3d t = {0.02, -0.01, 0.03}) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d(0.3, 1, 0.2).normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

// Surfels sampled from the scene in the model frame (= world here), with jitter and varied
// confidences, ages and colours, so that every branch of the kernels is exercised.
std::vector<Surfel> make_surfels(Size s, const Intrinsics& k, unsigned seed, const Eigen::Isometry3d& T_model_camera) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.002f, 0.002f), conf(0.0f, 12.0f), unit(0, 1);
  std::uniform_int_distribution<int> age(0, 60), byte(0, 255);
  const auto depth = scene_depth(s, k);
  Image<glm::vec4> v, n;
  kernels::reference::vertex_normal_map(depth, k, v, n);
  std::vector<Surfel> out;
  for (size_t i = 0; i < v.size(); ++i) {
    if (v.pixels[i].w == 0 || n.pixels[i].w == 0 || unit(rng) < 0.1f) continue;
    const Eigen::Vector3d p = T_model_camera * Eigen::Vector3d(v.pixels[i].x, v.pixels[i].y, v.pixels[i].z);
    const Eigen::Vector3d nn = T_model_camera.linear() * Eigen::Vector3d(n.pixels[i].x, n.pixels[i].y, n.pixels[i].z);
    Surfel sf{};
    sf.px = float(p.x()) + jitter(rng), sf.py = float(p.y()) + jitter(rng), sf.pz = float(p.z()) + jitter(rng);
    sf.nx = float(nn.x()), sf.ny = float(nn.y()), sf.nz = float(nn.z());
    sf.confidence = conf(rng);
    sf.radius_m = v.pixels[i].z / float(k.fx) * (0.5f + 2.0f * unit(rng));
    sf.colour_rgba8 = uint32_t(byte(rng)) | uint32_t(byte(rng)) << 8 | uint32_t(byte(rng)) << 16 | 0xFF000000u;
    sf.created_frame = 100 - age(rng);
    sf.last_seen_frame = 100;
    out.push_back(sf);
  }
  return out;
}

class SurfelKernels : public GpuTest {
 protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (!pre_) {
      pre_ = std::make_unique<kernels::Preprocessor>(ctx());
      pipes_ = std::make_unique<slam::SurfelPipelines>(ctx(), *pre_);
    }
  }
  static void TearDownTestSuite() {
    pipes_.reset();
    pre_.reset();
    GpuTest::TearDownTestSuite();
  }
  template <typename T>
  std::vector<T> download(const gpu::BufferPtr& b, size_t n) {
    return stream().template download<T>(b, n);
  }
  static std::unique_ptr<kernels::Preprocessor> pre_;
  static std::unique_ptr<slam::SurfelPipelines> pipes_;
};
std::unique_ptr<kernels::Preprocessor> SurfelKernels::pre_;
std::unique_ptr<slam::SurfelPipelines> SurfelKernels::pipes_;

L::SplatParams splat_params(const Intrinsics& k, const Eigen::Isometry3d& T_camera_model, size_t count, uint32_t scale) {
  L::SplatParams p{};
  slam::to_rows(T_camera_model, p.T_camera_model);
  p.fx = float(k.fx), p.fy = float(k.fy), p.cx = float(k.cx), p.cy = float(k.cy);
  p.width = uint32_t(k.width) * scale, p.height = uint32_t(k.height) * scale;
  p.surfel_count = uint32_t(count);
  p.min_confidence = 5.0f;
  p.frame = 100;
  p.recent_window_frames = 30;
  p.grid_scale = scale;
  p.footprint_px = 1;
  p.offset_penalty_rel = 0.002f;
  return p;
}

bool same_surfel(const Surfel& a, const Surfel& b, float tol) {
  const auto close = [&](float x, float y) { return std::abs(x - y) <= tol * (1 + std::abs(y)); };
  const auto colour_close = [](uint32_t x, uint32_t y) {
    for (int c = 0; c < 3; ++c)
      if (std::abs(int((x >> (8 * c)) & 0xFF) - int((y >> (8 * c)) & 0xFF)) > 1) return false;
    return true;
  };
  return close(a.px, b.px) && close(a.py, b.py) && close(a.pz, b.pz) && close(a.nx, b.nx) && close(a.ny, b.ny) &&
         close(a.nz, b.nz) && close(a.confidence, b.confidence) && close(a.radius_m, b.radius_m) &&
         colour_close(a.colour_rgba8, b.colour_rgba8) && a.created_frame == b.created_frame &&
         a.last_seen_frame == b.last_seen_frame;
}

// Tolerance for splatting: the projected depth/pixel may differ by float rounding between the CPU
// and the driver, so at most 0.2% of cells may disagree on their winner or on being empty.
TEST_F(SurfelKernels, SplatMatchesReference) {
  for (Size s : kSizes)
    for (uint32_t scale : {1u, 4u}) {
      const Intrinsics k = intrinsics_for(s);
      const auto T = test_pose();
      const auto surfels = make_surfels(s, k, 1, T.inverse());
      const auto p = splat_params(k, Eigen::Isometry3d(test_pose(0.0, {0, 0, 0})), surfels.size(), scale);
      auto grid = gpu::Buffer::create(ctx(), size_t(p.width) * p.height * 8, "grid");
      auto sb = upload(surfels, "surfels");
      stream().run([&](gpu::CommandList& c) {
        c.fill(grid, 0xFFFFFFFFu);
        c.barrier();
        pipes_->splat(c, sb, grid, p);
      });
      const auto gpu = download<uint64_t>(grid, size_t(p.width) * p.height);
      const auto cpu = ref::splat(surfels, p);
      size_t differ = 0, filled = 0;
      for (size_t i = 0; i < cpu.size(); ++i) {
        filled += cpu[i] != ~uint64_t{0};
        differ += (gpu[i] & 0xFFFFFFFFu) != (cpu[i] & 0xFFFFFFFFu);
      }
      EXPECT_LE(differ, cpu.size() / 500) << name(s) << " scale " << scale;
      if (s.width >= 160) {
        EXPECT_GT(filled, cpu.size() / 4) << "test scene covers too little of the view";
      }
    }
}

TEST_F(SurfelKernels, ResolveAndSubsampleMatchReference) {
  for (Size s : kSizes) {
    const Intrinsics k = intrinsics_for(s);
    const auto T_camera_model = test_pose();
    const auto surfels = make_surfels(s, k, 2, T_camera_model.inverse());
    const auto sp = splat_params(k, T_camera_model, surfels.size(), 1);
    const auto grid = ref::splat(surfels, sp);
    L::ResolveParams rp{};
    std::copy(sp.T_camera_model, sp.T_camera_model + 12, rp.T_camera_model);
    rp.fx = sp.fx, rp.fy = sp.fy, rp.cx = sp.cx, rp.cy = sp.cy, rp.width = sp.width, rp.height = sp.height;
    rp.x1 = rp.area_x1 = sp.width, rp.y1 = rp.area_y1 = sp.height;
    auto prediction = slam::ModelPrediction::allocate(ctx(), k, 2, "prediction");
    auto sb = upload(surfels, "surfels"), gb = upload(grid, "grid");
    stream().run([&](gpu::CommandList& c) {
      pipes_->resolve(c, sb, gb, prediction.levels[0], prediction.index_map, rp);
      c.barrier();
      pipes_->subsample(c, prediction.levels[0], prediction.levels[1]);
    });
    const auto cpu0 = ref::resolve(surfels, grid, rp);
    const auto cpu1 = ref::subsample(cpu0);
    for (int l = 0; l < 2; ++l) {
      const auto& cpu = l == 0 ? cpu0 : cpu1;
      const auto& level = prediction.levels[l];
      const size_t n = size_t(level.width) * level.height;
      ASSERT_EQ(n, cpu.vertex.size());
      const auto v = download<glm::vec4>(level.vertex, n), nn = download<glm::vec4>(level.normal, n);
      const auto in = download<float>(level.intensity, n);
      int bad = 0;
      // Tolerance: 1e-5 relative on vertices and normals (a handful of float operations).
      for (size_t i = 0; i < n; ++i)
        if (v[i].w != cpu.vertex.pixels[i].w || glm::length(glm::vec3(v[i] - cpu.vertex.pixels[i])) > 1e-5f * (1 + v[i].z) ||
            glm::length(glm::vec3(nn[i] - cpu.normal.pixels[i])) > 1e-5f || std::abs(in[i] - cpu.intensity.pixels[i]) > 1e-3f)
          ++bad;
      EXPECT_EQ(bad, 0) << name(s) << " level " << l;
    }
    EXPECT_EQ(download<uint32_t>(prediction.index_map, cpu0.index.size()), cpu0.index.pixels) << name(s);
  }
}

// Prediction restricted to rectangles, one after another on the same buffers (as a tracked
// object's is, frame after frame): every map of every level equals the references' whole-view
// prediction from the same keys with nothing outside the rectangle, so no pixel of an earlier,
// larger rectangle is left behind. The keys are the GPU's (the splat has its own test).
TEST_F(SurfelKernels, PredictionInRectanglesMatchesReference) {
  for (Size s : kSizes) {
    const Intrinsics k = intrinsics_for(s);
    const auto T_camera_model = test_pose();
    const auto surfels = make_surfels(s, k, 3, T_camera_model.inverse());
    slam::SurfelModel model(ctx(), 1, unsigned(surfels.size()) + 1);
    model.upload(stream(), surfels);
    auto prediction = slam::ModelPrediction::allocate(ctx(), k, 3, "prediction");
    const int w = s.width, h = s.height;
    const std::optional<PixelRect> rects[] = {std::nullopt,
                                              PixelRect{w / 4, h / 4, w / 2 + 3, h / 2 + 1},
                                              PixelRect{w / 3, h / 5, w, h},
                                              PixelRect{},
                                              PixelRect{-5, -5, 7, 9},
                                              PixelRect{w / 2, 0, w / 2 + 1, h},
                                              std::nullopt};
    int call = 0;
    for (const auto& rect : rects) {
      const std::string what = name(s) + " call " + std::to_string(call);
      // A little motion between calls, so that stale pixels would differ.
      const auto T = test_pose(0.002 * call, {0.001 * call, 0, 0}) * T_camera_model;
      stream().run([&](gpu::CommandList& c) { pipes_->predict(c, model, T, prediction, {}, 100, rect); });
      ++call;
      const PixelRect area = rect ? rect->clamped(w, h) : PixelRect::full(w, h);
      EXPECT_EQ(prediction.written, area) << what;
      L::ResolveParams rp{};
      slam::to_rows(T, rp.T_camera_model);
      rp.fx = float(k.fx), rp.fy = float(k.fy), rp.cx = float(k.cx), rp.cy = float(k.cy);
      rp.width = uint32_t(w), rp.height = uint32_t(h);
      rp.area_x0 = uint32_t(area.x0), rp.area_y0 = uint32_t(area.y0), rp.area_x1 = uint32_t(area.x1),
      rp.area_y1 = uint32_t(area.y1);
      const auto keys = download<uint64_t>(prediction.depth_index, size_t(w) * h);
      std::vector<ref::PredictedMaps> cpu{ref::resolve(surfels, keys, rp)};
      if (!area.empty() && s.width >= 160) {
        size_t filled = 0;
        for (uint32_t i : cpu[0].index.pixels) filled += i != 0xFFFFFFFFu;
        EXPECT_GT(filled, 0u) << what << ": the rectangle must see part of the scene";
      }
      for (size_t l = 1; l < prediction.levels.size(); ++l) cpu.push_back(ref::subsample(cpu.back()));
      EXPECT_EQ(download<uint32_t>(prediction.index_map, size_t(w) * h), cpu[0].index.pixels) << what;
      for (size_t l = 0; l < prediction.levels.size(); ++l) {
        const auto& level = prediction.levels[l];
        const size_t n = size_t(level.width) * level.height;
        ASSERT_EQ(n, cpu[l].vertex.size());
        const auto v = download<glm::vec4>(level.vertex, n), nn = download<glm::vec4>(level.normal, n);
        const auto in = download<float>(level.intensity, n);
        const auto g = download<glm::vec2>(level.gradient, n);
        const auto g_cpu = kernels::reference::intensity_gradient(cpu[l].intensity);
        int bad = 0;
        for (size_t i = 0; i < n; ++i)
          if (v[i].w != cpu[l].vertex.pixels[i].w ||
              glm::length(glm::vec3(v[i] - cpu[l].vertex.pixels[i])) > 1e-5f * (1 + std::abs(v[i].z)) ||
              glm::length(glm::vec3(nn[i] - cpu[l].normal.pixels[i])) > 1e-5f ||
              std::abs(in[i] - cpu[l].intensity.pixels[i]) > 1e-3f || glm::length(g[i] - g_cpu.pixels[i]) > 1e-3f)
            ++bad;
        EXPECT_EQ(bad, 0) << what << " level " << l;
      }
    }
  }
}

// Fusion's sizes: also a rectangle of 2^20 pixels, where fuse_count_new and fuse_update find a
// pixel's row by integer division (shared/fuse_rect.glsl; below it, by a float quotient).
const Size kFusionSizes[] = {{1, 1}, {37, 23}, {160, 120}, {640, 480}, {1024, 1024}};

TEST_F(SurfelKernels, AssociateUpdateAndCleanupMatchReference) {
  for (Size s : kFusionSizes) {
    const bool large = uint64_t(s.width) * uint64_t(s.height) >= SMALL_QUOTIENT_LIMIT;
    const Intrinsics k = intrinsics_for(s);
    // The live frame sees the scene from the identity pose; the model (built from a slightly
    // different view) is seen at T_camera_model.
    const auto depth = scene_depth(s, k);
    ref::LiveMaps live;
    kernels::reference::vertex_normal_map(depth, k, live.vertex, live.normal);
    std::mt19937 rng(3);
    std::uniform_int_distribution<int> byte(0, 255);
    live.rgb.resize(size_t(s.width) * s.height * 3);
    for (auto& b : live.rgb) b = uint8_t(byte(rng));
    live.labels.resize(size_t(s.width) * s.height);
    // Labels 1 and 3 are fused (a model and a resting one it fuses for); 2 and 255 (no slot) not.
    for (size_t i = 0; i < live.labels.size(); ++i)
      live.labels[i] = i % 11 == 0 ? 255u : (i / 7) % 4 == 0 ? 2u : (i / 7) % 4 == 1 ? 3u : 1u;
    const auto T_camera_model = test_pose(0.002, {0.001, 0.0, -0.001});
    auto surfels = make_surfels(s, k, 4, T_camera_model.inverse());
    const uint32_t capacity = uint32_t(surfels.size() + live.labels.size());

    // Every pixel; the pixels labelled 1 or 3; those of them in a rectangle (a model's region); each
    // with the index map at 4 cells per pixel and at 2 (the default, the association's unrolled path).
    for (int run = 0; run < 6; ++run) {
      if (large && run != 3) continue;  // the large image: every pixel at the default scale only
      const int variant = run % 3;
      const uint32_t scale = run < 3 ? 4u : 2u;
      const uint32_t use_labels = variant > 0 ? 1u : 0u;
      const PixelRect rect = variant == 2 ? PixelRect{s.width / 3, s.height / 5, s.width / 3 + (s.width + 1) / 2, s.height + 4}
                                          : PixelRect::full(s.width, s.height);
      const std::string what = name(s) + " scale " + std::to_string(scale) + (variant == 0 ? "" : variant == 1 ? " labelled" : " labelled, in a rectangle");
      const auto sp = splat_params(k, T_camera_model, surfels.size(), scale);
      const auto grid = ref::splat(surfels, sp);
      L::FuseParams fp{};
      std::copy(sp.T_camera_model, sp.T_camera_model + 12, fp.T_camera_model);
      fp.fx = sp.fx, fp.fy = sp.fy, fp.cx = sp.cx, fp.cy = sp.cy;
      fp.width = uint32_t(s.width), fp.height = uint32_t(s.height);
      fp.grid_scale = scale, fp.surfel_count = uint32_t(surfels.size()), fp.capacity = capacity, fp.frame = 101;
      fp.max_depth_diff_rel = 0.03f, fp.min_normal_dot = std::cos(20.0f * float(M_PI) / 180.0f);
      fp.max_radius_growth = 1.5f, fp.label_mask = use_labels ? (1u << 1) | (1u << 3) : FUSE_ALL_LABELS;
      fp.new_surfel_clearance_cells = variant == 1 ? 0u : 1u;
      fp.rect_x0 = uint32_t(rect.x0), fp.rect_y0 = uint32_t(rect.y0), fp.rect_x1 = uint32_t(rect.x1),
      fp.rect_y1 = uint32_t(rect.y1);
      fp.colour_gain = variant == 1 ? 0.8f : 1.0f;  // an exposure gain on the labelled variant

      std::vector<Surfel> storage = surfels;
      storage.resize(capacity);
      slam::SurfelPipelines::FuseBuffers b{upload(storage, "surfels"),
                                           upload(grid, "grid"),
                                           upload(live.vertex.pixels),
                                           upload(live.normal.pixels),
                                           upload(live.rgb),
                                           gpu::Buffer::create(ctx(), live.labels.size() * 4, "assoc"),
                                           gpu::Buffer::create(ctx(), capacity * 4, "claim"),
                                           upload(std::vector<uint32_t>{uint32_t(surfels.size()), 0, 0, 0}),
                                           upload(live.labels),
                                           gpu::Buffer::create(ctx(), kernels::CompactionScan::blocks_bytes(uint32_t(rect.clamped(s.width, s.height).area())), "blocks")};
      stream().run([&](gpu::CommandList& c) {
        c.fill(b.claim, 0xFFFFFFFFu);
        c.fill(b.assoc, FUSE_SKIP_PIXEL);  // outside the rectangle nothing may be written
        c.barrier();
        pipes_->associate(c, b, fp);
      });
      const auto cpu_assoc = ref::associate(surfels, grid, live, fp);
      const auto gpu_assoc = download<uint32_t>(b.assoc, cpu_assoc.assoc.size());
      size_t differ = 0, associated = 0;
      for (size_t i = 0; i < gpu_assoc.size(); ++i) {
        differ += gpu_assoc[i] != cpu_assoc.assoc[i];
        associated += cpu_assoc.assoc[i] < FUSE_SKIP_PIXEL;
      }
      // Tolerance: depth/normal tests on rounding boundaries may flip for at most 0.2% of pixels.
      EXPECT_LE(differ, gpu_assoc.size() / 500) << what;
      if (s.width >= 160) {
        EXPECT_GT(associated, size_t(rect.clamped(s.width, s.height).area()) / 4) << "test data associates too little";
      }
      if (use_labels) {
        size_t outside_mask = 0, second_label = 0;
        for (size_t i = 0; i < gpu_assoc.size(); ++i) {
          const bool in_mask = live.labels[i] == 1u || live.labels[i] == 3u;
          outside_mask += !in_mask && gpu_assoc[i] != FUSE_SKIP_PIXEL;
          second_label += live.labels[i] == 3u && gpu_assoc[i] != FUSE_SKIP_PIXEL;
        }
        EXPECT_EQ(outside_mask, 0u) << "pixels labelled 2 or 255 are not fused, " << what;
        if (s.width >= 160) {
          EXPECT_GT(second_label, 0u) << "pixels labelled 3 are, " << what;
        }
      }

      // Update from the CPU association on both sides, so the comparison isolates the update.
      auto cpu_claim = cpu_assoc.claim;
      cpu_claim.resize(capacity, 0xFFFFFFFFu);
      stream().upload(b.assoc, cpu_assoc.assoc.data(), cpu_assoc.assoc.size() * 4);
      stream().upload(b.claim, cpu_claim.data(), cpu_claim.size() * 4);
      stream().run([&](gpu::CommandList& c) { pipes_->update(c, b, fp); });
      auto cpu_surfels = surfels;
      ref::update(cpu_surfels, cpu_assoc, live, fp);
      const uint32_t gpu_count = download<uint32_t>(b.counter, 1)[0];
      ASSERT_EQ(gpu_count, cpu_surfels.size()) << what;
      auto gpu_surfels = download<Surfel>(b.surfels, gpu_count);
      int bad = 0;
      // Tolerance 2e-5 relative: weighted averages and a normalisation in float.
      for (size_t i = 0; i < surfels.size(); ++i) bad += !same_surfel(gpu_surfels[i], cpu_surfels[i], 2e-5f);
      EXPECT_EQ(bad, 0) << "updated surfels " << what;
      // New surfels in pixel order on both sides.
      bad = 0;
      for (size_t i = surfels.size(); i < cpu_surfels.size(); ++i) bad += !same_surfel(gpu_surfels[i], cpu_surfels[i], 2e-5f);
      EXPECT_EQ(bad, 0) << "new surfels " << what;

      // Cleanup of the CPU result, on both sides, against a live depth with free space in front
      // of part of the model (the scene pushed 30 cm back on the left).
      auto pushed = depth;
      for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width / 2; ++x) pushed.at(x, y) += 0.3f;
      L::CleanupParams cp{};
      std::copy(sp.T_camera_model, sp.T_camera_model + 12, cp.T_camera_model);
      cp.fx = sp.fx, cp.fy = sp.fy, cp.cx = sp.cx, cp.cy = sp.cy, cp.width = fp.width, cp.height = fp.height;
      cp.surfel_count = capacity, cp.frame = 130, cp.stable_confidence = 6, cp.unstable_window_frames = 40;
      cp.free_space_margin_rel = 0.05f, cp.free_space_penalty = 3.0f;
      auto gpu_model = upload(cpu_surfels, "cleanup surfels");
      auto scratch = gpu::Buffer::create(ctx(), cpu_surfels.size() * sizeof(Surfel) + 48, "cleanup scratch");
      auto counter = upload(std::vector<uint32_t>{uint32_t(cpu_surfels.size()), 0, 0, 0});
      auto depth_buffer = upload(pushed.pixels);
      auto blocks = gpu::Buffer::create(ctx(), kernels::CompactionScan::blocks_bytes(cp.surfel_count), "blocks");
      auto keep_mask = gpu::Buffer::create(ctx(), kernels::CompactionScan::keep_mask_bytes(cp.surfel_count), "keep mask");
      // The cleanup runs over counter[0]'s surfels, not its bound (cp.surfel_count, the capacity):
      // blocks past them hold garbage that neither its scan nor its copy may read.
      auto groups = gpu::Buffer::create(ctx(), kernels::IndirectGroups::kBytes, "maintenance groups",
                                        gpu::BufferUsage::Indirect);
      stream().run([&](gpu::CommandList& c) {
        c.fill(blocks, 0x7777u);
        c.fill(keep_mask, 0xFFFFFFFFu);
        c.barrier();
        pipes_->maintenance_groups(c, counter, cp.surfel_count, groups);
        pipes_->cleanup(c, gpu_model, scratch, depth_buffer, counter, blocks, keep_mask, cp, groups);
      });
      auto cpu_kept = ref::cleanup(cpu_surfels, pushed, cp);
      const uint32_t kept = download<uint32_t>(counter, 2)[1];
      ASSERT_EQ(kept, cpu_kept.size()) << name(s);
      if (s.width >= 160) {
        EXPECT_LT(kept, cpu_surfels.size()) << "cleanup removed nothing: test data too easy";
      }
      // Kept surfels in their order on both sides, compacted back into the model's buffer.
      auto gpu_kept = download<Surfel>(gpu_model, kept);
      bad = 0;
      for (size_t i = 0; i < cpu_kept.size(); ++i) bad += !same_surfel(gpu_kept[i], cpu_kept[i], 1e-6f);
      EXPECT_EQ(bad, 0) << "cleanup " << name(s);
    }
  }
}

// Surfels with near copies (duplicates a merge must find) and copies on another surface (normal
// 60 degrees off: no merge), with random confidences; some copies tie in confidence.
std::vector<Surfel> with_copies(std::vector<Surfel> surfels, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> offset(-0.25f, 0.25f), conf(0.0f, 12.0f);
  const size_t n = surfels.size();
  for (size_t i = 0; i < n; ++i) {
    Surfel c = surfels[i];
    if (i % 3 == 0) {
      c.px += offset(rng) * c.radius_m, c.py += offset(rng) * c.radius_m, c.pz += offset(rng) * c.radius_m;
      const glm::vec3 nn = glm::normalize(glm::vec3(c.nx, c.ny, c.nz) + glm::vec3(offset(rng), offset(rng), 0.0f) * 0.5f);
      c.nx = nn.x, c.ny = nn.y, c.nz = nn.z;
      c.confidence = i % 9 == 0 ? surfels[i].confidence : conf(rng);
      c.created_frame -= 3, c.last_seen_frame = 99;
      surfels.push_back(c);
    } else if (i % 7 == 0) {
      const glm::vec3 nn = glm::normalize(glm::vec3(c.nx, c.ny, c.nz));
      const glm::vec3 side = glm::normalize(glm::cross(nn, glm::vec3(0.3f, 1.0f, 0.1f)));
      const glm::vec3 turned = 0.5f * nn + 0.8660254f * side;  // 60 degrees
      c.nx = turned.x, c.ny = turned.y, c.nz = turned.z;
      c.confidence = conf(rng);
      surfels.push_back(c);
    }
  }
  return surfels;
}

// surfel_merge_select, surfel_merge_claim and the merging cleanup against their references, over
// edge sizes (an empty model included), with and without labels and a rectangle, searching every
// cell of the window or every second one, with the index map at 2 cells per pixel (the default)
// and at 3 (cells to pixels by a quotient that is not a shift: shared/small_division.glsl).
TEST_F(SurfelKernels, MergeSelectClaimAndCleanupMatchReference) {
  const Size sizes[] = {{37, 23}, {1, 1}, {37, 23}, {160, 120}, {640, 480}, {160, 120}};
  for (size_t case_index = 0; case_index < std::size(sizes); ++case_index) {
    const Size s = sizes[case_index];
    const uint32_t scale = case_index == 2 || case_index == 5 ? 3u : 2u;
    const Intrinsics k = intrinsics_for(s);
    const auto T_camera_model = test_pose(0.002, {0.001, 0.0, -0.001});
    const auto surfels = case_index == 0 ? std::vector<Surfel>{} : with_copies(make_surfels(s, k, 6, T_camera_model.inverse()), 7);
    const uint32_t n = uint32_t(surfels.size());
    auto sp = splat_params(k, T_camera_model, n, scale);
    sp.min_confidence = 0.0f, sp.recent_window_frames = 0;  // as fusion splats
    const auto grid = ref::splat(surfels, sp);
    std::vector<uint32_t> labels(size_t(s.width) * s.height);
    for (size_t i = 0; i < labels.size(); ++i) labels[i] = i % 13 == 0 ? 255u : (i / 5) % 4 == 0 ? 2u : (i / 5) % 4 == 1 ? 3u : 1u;
    for (int variant = 0; variant < 4; ++variant) {
      const bool labelled = variant % 2 == 1;
      const uint32_t step = variant < 2 ? 1u : 2u;
      const std::string what = (case_index == 0 ? "empty model " : "") + name(s) + (labelled ? " labelled, in a rectangle" : "") +
                               ", window step " + std::to_string(step) + ", scale " + std::to_string(scale);
      L::MergeParams mp{};
      std::copy(sp.T_camera_model, sp.T_camera_model + 12, mp.T_camera_model);
      mp.fx = sp.fx, mp.fy = sp.fy, mp.cx = sp.cx, mp.cy = sp.cy;
      // The passes' bound lies past the model's count (counter[0]), as fusion's does: they run over
      // the count (maintenance_groups), and what lies past it is never read.
      const uint32_t bound = n + 2 * COMPACTION_BLOCK + 5;
      mp.width = uint32_t(s.width), mp.height = uint32_t(s.height), mp.grid_scale = scale, mp.surfel_count = bound;
      const PixelRect rect = labelled ? PixelRect{s.width / 4, s.height / 3, s.width, (3 * s.height + 3) / 4}
                                      : PixelRect::full(s.width, s.height);
      mp.rect_x0 = uint32_t(rect.x0), mp.rect_y0 = uint32_t(rect.y0), mp.rect_x1 = uint32_t(rect.x1),
      mp.rect_y1 = uint32_t(rect.y1);
      mp.window_cells = 2, mp.distance_rel = 0.5f, mp.min_normal_dot = std::cos(35.0f * float(M_PI) / 180.0f);
      mp.max_source_confidence = 8.0f, mp.window_step = step;
      mp.use_labels = uint32_t(labelled), mp.label_mask = (1u << 1) | (1u << 3);
      const size_t slots = std::max<size_t>(n, 4);
      slam::SurfelPipelines::MergeBuffers b{upload(surfels.empty() ? std::vector<Surfel>(1) : surfels, "surfels"),
                                            upload(grid, "grid"),
                                            gpu::Buffer::create(ctx(), slots * 4, "target"),
                                            gpu::Buffer::create(ctx(), slots * 4, "claim"),
                                            upload(std::vector<uint32_t>{n, 0, 0, 0}),
                                            upload(labels, "labels")};
      auto groups = gpu::Buffer::create(ctx(), kernels::IndirectGroups::kBytes, "maintenance groups",
                                        gpu::BufferUsage::Indirect);
      stream().run([&](gpu::CommandList& c) {
        pipes_->maintenance_groups(c, b.counter, bound, groups);
        pipes_->merge_select(c, b, mp, groups);
      });
      const auto cpu_target = ref::merge_select(surfels, grid, labels, mp);
      const auto gpu_target = download<uint32_t>(b.target, n);
      size_t differ = 0, merging = 0;
      for (size_t i = 0; i < n; ++i) {
        differ += gpu_target[i] != cpu_target[i];
        merging += cpu_target[i] != MERGE_NONE;
      }
      // Tolerance: projections and distances on rounding boundaries may flip for 0.2% of surfels.
      EXPECT_LE(differ, size_t(n) / 500) << what;
      if (s.width >= 160) {
        EXPECT_GT(merging, size_t(n) / (labelled ? 40 : 10)) << "test data merges too little: " << what;
      }

      // The claims from the CPU's targets on both sides: exact.
      if (n > 0) stream().upload(b.target, cpu_target.data(), size_t(n) * 4);
      stream().run([&](gpu::CommandList& c) {
        c.fill(b.claim, MERGE_NONE);
        c.barrier();
        pipes_->merge_claim(c, b, mp, groups);
      });
      const auto cpu_claim = ref::merge_claim(cpu_target);
      EXPECT_EQ(download<uint32_t>(b.claim, n), cpu_claim) << what;

      // The cleanup applying the CPU's merges, on both sides.
      if (n > 0) stream().upload(b.claim, cpu_claim.data(), size_t(n) * 4);
      L::CleanupParams cp{};
      std::copy(sp.T_camera_model, sp.T_camera_model + 12, cp.T_camera_model);
      cp.fx = sp.fx, cp.fy = sp.fy, cp.cx = sp.cx, cp.cy = sp.cy, cp.width = mp.width, cp.height = mp.height;
      cp.surfel_count = bound, cp.frame = 110, cp.stable_confidence = 6, cp.unstable_window_frames = 40;
      cp.free_space_margin_rel = 0.05f, cp.free_space_penalty = 1.0f, cp.merge = 1;
      const Image<float> no_depth(s.width, s.height);
      auto scratch = gpu::Buffer::create(ctx(), slots * sizeof(Surfel), "cleanup scratch");
      auto counter = upload(std::vector<uint32_t>{n, 0, 0, 0});
      auto depth_buffer = upload(no_depth.pixels);
      auto blocks = gpu::Buffer::create(ctx(), kernels::CompactionScan::blocks_bytes(bound), "blocks");
      auto keep_mask = gpu::Buffer::create(ctx(), kernels::CompactionScan::keep_mask_bytes(bound), "keep mask");
      stream().run([&](gpu::CommandList& c) {
        c.fill(blocks, 0x7777u);  // garbage past the count's blocks
        c.fill(keep_mask, 0xFFFFFFFFu);
        c.barrier();
        pipes_->maintenance_groups(c, counter, bound, groups);
        pipes_->cleanup(c, b.surfels, scratch, depth_buffer, counter, blocks, keep_mask, cp, groups, b.target, b.claim);
      });
      auto cpu_kept = ref::cleanup(surfels, no_depth, cp, ref::Merges{cpu_target, cpu_claim});
      const uint32_t kept = download<uint32_t>(counter, 2)[1];
      ASSERT_EQ(kept, cpu_kept.size()) << what;
      auto gpu_kept = download<Surfel>(b.surfels, kept);  // in order, as the CPU's, back in place
      int bad = 0;
      for (size_t i = 0; i < cpu_kept.size(); ++i) bad += !same_surfel(gpu_kept[i], cpu_kept[i], 2e-5f);
      EXPECT_EQ(bad, 0) << "merging cleanup " << what;
    }
  }
}

// Depth of scene_depth's scene (world frame = the identity camera's) seen by a camera at
// T_world_camera.
Image<float> scene_depth_from(Size s, const Intrinsics& k, const Eigen::Isometry3d& T_world_camera) {
  Image<float> d(s.width, s.height);
  const Eigen::Vector3d o = T_world_camera.translation(), centre(0.2, 0.0, 1.5);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x) {
      const Eigen::Vector3d ray_c((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);  // camera depth = t
      const Eigen::Vector3d r = T_world_camera.linear() * ray_c;
      double t = (2.5 - o.z()) / r.z();
      if (r.y() > 0.1 * r.z()) t = std::min(t, (0.9 - o.y()) / r.y());
      const Eigen::Vector3d oc = o - centre;
      const double a = r.squaredNorm(), b = oc.dot(r), c = oc.squaredNorm() - 0.09;
      if (b * b - a * c > 0) t = std::min(t, (-b - std::sqrt(b * b - a * c)) / a);
      d.at(x, y) = float(t);
    }
  return d;
}

// A static scene seen from a camera that turns back and forth (TUM fr1/rpy in small): with
// merging the model keeps to about one surfel per surface pixel; without, every new view adds
// surfels between the known ones.
TEST_F(SurfelKernels, MergingKeepsTheModelOfAStaticSceneFromGrowing) {
  const Size s{160, 120};
  const Intrinsics k = intrinsics_for(s);
  std::vector<uint8_t> rgb(size_t(s.width) * s.height * 3, 128);
  kernels::PreprocessParams pp;
  pp.bilateral = false;
  auto frame = kernels::FramePyramid::allocate(ctx(), k, 3, "live");
  slam::FusionParams merging, not_merging;
  not_merging.merge_distance_rel = 0.0f;
  slam::SurfelModel with(ctx(), 0, 1024), without(ctx(), 1, 1024);
  size_t first_view_surfels = 0;
  for (int f = 0; f < 16; ++f) {
    Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
    T_world_camera.linear() = (Eigen::AngleAxisd(0.02 * std::sin(0.9 * f), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.015 * std::sin(1.7 * f), Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(0.03 * std::sin(0.6 * f), Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
    const auto depth = scene_depth_from(s, k, T_world_camera);
    frame.upload(stream(), depth.pixels.data(), rgb.data());
    stream().run([&](gpu::CommandList& c) { pre_->record_frame(c, frame, kernels::FramePyramid::kUploadMetresPerUnit, pp); });
    pipes_->fuse(stream(), with, frame, T_world_camera.inverse(), f, merging);
    pipes_->fuse(stream(), without, frame, T_world_camera.inverse(), f, not_merging);
    if (f == 0) first_view_surfels = with.count();
  }
  const auto stats = [&](slam::SurfelModel& m) {
    std::vector<eval::MapSurfel> map;
    for (const auto& sf : m.download(stream()))
      map.push_back({Eigen::Vector3f(sf.px, sf.py, sf.pz), Eigen::Vector3f(sf.nx, sf.ny, sf.nz), sf.radius_m, sf.confidence});
    return eval::compute_surfel_map_stats(map);
  };
  const auto a = stats(with), b = stats(without);
  std::printf("first view %zu surfels; after 16 views: merging %zu (%.1f%% duplicates), not merging %zu (%.1f%%)\n",
              first_view_surfels, a.surfels, 100 * a.duplicate_share, b.surfels, 100 * b.duplicate_share);
  // Measured with the defaults: 12.5k surfels merging, 19.7k not (first view 18.6k). The duplicate
  // share of this small 160x120 scene stays at about 18 % either way (TUM fr1/rpy: 44 % -> 4 %):
  // not yet understood, so only bounded by the unmerged model's here.
  EXPECT_LT(double(a.surfels), 0.8 * double(b.surfels));
  EXPECT_LT(double(a.surfels), 1.05 * double(first_view_surfels)) << "the views overlap: the model must not grow much";
  EXPECT_LE(a.duplicate_share, b.duplicate_share + 0.01);
}

// The model end to end: fuse a frame into an empty model, predict it back from the same pose,
// fuse the same frame again.
TEST_F(SurfelKernels, FusedFramePredictsItselfAndRefusionAddsConfidence) {
  const Size s{160, 120};
  const Intrinsics k = intrinsics_for(s);
  const auto depth = scene_depth(s, k);
  std::vector<uint8_t> rgb(size_t(s.width) * s.height * 3, 128);
  kernels::PreprocessParams pp;
  pp.bilateral = false;
  auto frame = kernels::FramePyramid::allocate(ctx(), k, 3, "live");
  frame.upload(stream(), depth.pixels.data(), rgb.data());
  stream().run([&](gpu::CommandList& c) { pre_->record_frame(c, frame, kernels::FramePyramid::kUploadMetresPerUnit, pp); });

  slam::SurfelModel model(ctx(), 0, 1024);  // small on purpose: fusion must grow it
  slam::FusionParams fusion;
  const auto T = test_pose(0.1, {0.2, 0.1, -0.3});  // model frame != camera frame
  const auto stats = pipes_->fuse(stream(), model, frame, T, 0, fusion);
  Image<glm::vec4> v, n;
  kernels::reference::vertex_normal_map(depth, k, v, n);
  size_t valid = 0;
  for (size_t i = 0; i < v.size(); ++i) valid += v.pixels[i].w > 0 && n.pixels[i].w > 0;
  EXPECT_EQ(stats.surfels_before, 0u);
  EXPECT_EQ(model.count(), valid) << "one surfel per valid pixel";
  EXPECT_GE(model.capacity(), model.count());

  auto prediction = slam::ModelPrediction::allocate(ctx(), k, 3, "prediction");
  stream().run([&](gpu::CommandList& c) { pipes_->predict(c, model, T, prediction, slam::PredictionParams{}, 0); });
  const auto pv = download<glm::vec4>(prediction.levels[0].vertex, v.size());
  size_t compared = 0, close = 0;
  for (size_t i = 0; i < v.size(); ++i) {
    if (v.pixels[i].w == 0 || pv[i].w == 0) continue;
    ++compared;
    close += glm::length(glm::vec3(pv[i] - v.pixels[i])) < 0.002f;
  }
  EXPECT_GT(compared, valid * 9 / 10);
  EXPECT_GT(close, compared * 95 / 100) << "predicted vertices within 2 mm of the fused ones";

  const auto before = model.download(stream());
  double confidence_before = 0;
  for (const auto& sf : before) confidence_before += sf.confidence;
  pipes_->fuse(stream(), model, frame, T, 1, fusion);
  EXPECT_NEAR(double(model.count()), double(valid), valid * 0.02) << "re-fusing the same view adds almost nothing";
  double confidence_after = 0;
  for (const auto& sf : model.download(stream())) confidence_after += sf.confidence;
  EXPECT_GT(confidence_after, confidence_before * 1.8);
}

// Fusing a model's labelled pixels through their bounding rectangle gives the model that fusing
// them over the whole image gives (the index map is cleared only in the rectangle's rows, so the
// second fusion also checks that nothing outside is read).
TEST_F(SurfelKernels, FusionInTheLabelsRectangleEqualsWholeImageFusion) {
  const Size s{160, 120};
  const Intrinsics k = intrinsics_for(s);
  const auto depth = scene_depth(s, k);
  std::vector<uint8_t> rgb(size_t(s.width) * s.height * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = uint8_t((i * 37) % 251);
  kernels::PreprocessParams pp;
  pp.bilateral = false;
  auto frame = kernels::FramePyramid::allocate(ctx(), k, 3, "live");
  frame.upload(stream(), depth.pixels.data(), rgb.data());
  stream().run([&](gpu::CommandList& c) { pre_->record_frame(c, frame, kernels::FramePyramid::kUploadMetresPerUnit, pp); });
  const PixelRect rect{37, 21, 101, 90};
  std::vector<uint32_t> labels(size_t(s.width) * s.height, 0u);
  for (int y = rect.y0; y < rect.y1; ++y)
    for (int x = rect.x0; x < rect.x1; ++x) labels[size_t(y) * s.width + x] = (x + y) % 5 == 0 ? 0u : 3u;
  auto label_buffer = upload(labels, "labels");

  // With merging: which duplicate merges into which depends on the surfels' indices, and new and
  // kept surfels take their places in a fixed order, so the two models are equal surfel by surfel.
  slam::FusionParams fusion;
  const auto T0 = test_pose(0.1, {0.2, 0.1, -0.3});
  const auto T1 = test_pose(0.004, {0.1, 1, 0}) * T0;  // a little motion: association and new surfels
  slam::SurfelModel whole(ctx(), 1, 1024), in_rect(ctx(), 2, 1024);
  for (auto* m : {&whole, &in_rect}) pipes_->fuse(stream(), *m, frame, T0, 0, fusion);
  pipes_->fuse(stream(), whole, frame, T1, 1, fusion, label_buffer, 3u);
  pipes_->fuse(stream(), in_rect, frame, T1, 1, fusion, label_buffer, 3u, rect);
  auto a = whole.download(stream()), b = in_rect.download(stream());
  ASSERT_EQ(a.size(), b.size());
  int bad = 0, fused = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    bad += !same_surfel(a[i], b[i], 1e-6f);
    fused += a[i].last_seen_frame == 1;
  }
  EXPECT_EQ(bad, 0);
  EXPECT_GT(fused, rect.area() / 2) << "the second fusion must touch the rectangle's pixels";
}

TEST_F(SurfelKernels, ModelTooLargeForTheDeviceFailsWithItsId) {
  slam::SurfelModel model(ctx(), 7, 1024);
  try {
    model.reserve(stream(), model.max_capacity() + 1u);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("model 7"));
  }
}

// On a slanted surface every covered pixel must take the surfel whose projection is nearest to it
// (keyed by the surfel centre's depth, the nearer side's surfels won every footprint and shifted
// the predicted colours by a pixel), while a surface 3 cm in front still hides the one behind.
TEST(SplatReference, SlantedSurfaceGivesEachPixelItsNearestSurfelAndKeepsOcclusion) {
  const int w = 160, h = 120;
  const double fx = 150, fy = 150, cx = 79.5, cy = 59.5;
  // Plane through (0, 0, 1) m tilted 55 degrees about the x axis (a table seen from above).
  const Eigen::Vector3d n = Eigen::Vector3d(0, -std::sin(55 * M_PI / 180), -std::cos(55 * M_PI / 180)).normalized();
  const Eigen::Vector3d p0(0, 0, 1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> offset(-0.45, 0.45);
  std::vector<Surfel> surfels;
  std::vector<Eigen::Vector2d> projected;
  auto add = [&](double u, double v, const Eigen::Vector3d& normal, const Eigen::Vector3d& point) {
    const Eigen::Vector3d ray((u - cx) / fx, (v - cy) / fy, 1);
    const Eigen::Vector3d x = ray * (normal.dot(point) / normal.dot(ray));
    Surfel s{};
    s.px = float(x.x()), s.py = float(x.y()), s.pz = float(x.z());
    s.nx = float(normal.x()), s.ny = float(normal.y()), s.nz = float(normal.z());
    s.confidence = 10;
    s.radius_m = float(1.41 * x.z() / fx / std::max(std::abs(normal.dot(ray.normalized())), 0.3));
    s.colour_rgba8 = 0xFFFFFFFFu;
    surfels.push_back(s);
    projected.emplace_back(fx * s.px / s.pz + cx, fy * s.py / s.pz + cy);
  };
  for (int v = 0; v < h; v += 1)
    for (int u = 0; u < w; u += 1) add(u + offset(rng), v + offset(rng), n, p0);
  const size_t plane_surfels = surfels.size();
  // A parallel patch 3 cm in front of the plane (n faces the camera); its surfels are a third as
  // dense, so the plane's surfels are nearer in the image to most pixels the patch covers.
  for (int v = 45; v < 75; v += 3)
    for (int u = 65; u < 95; u += 3) add(u, v, n, p0 + 0.03 * n);

  L::SplatParams p{};
  const float T[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  std::copy(T, T + 12, p.T_camera_model);
  p.fx = float(fx), p.fy = float(fy), p.cx = float(cx), p.cy = float(cy);
  p.width = w, p.height = h;
  p.surfel_count = uint32_t(surfels.size());
  p.recent_window_frames = 1 << 30;
  p.grid_scale = 1;
  p.footprint_px = 1;
  p.offset_penalty_rel = slam::PredictionParams{}.offset_penalty_rel;
  const auto grid = ref::splat(surfels, p);

  int plane_pixels = 0, nearest = 0, patch_pixels = 0, patch_wins = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint64_t key = grid[size_t(y) * w + x];
      if (x >= 67 && x < 90 && y >= 47 && y < 70) {  // inside the patch's footprint
        ++patch_pixels;
        patch_wins += key != ~uint64_t{0} && (key & 0xFFFFFFFFu) >= plane_surfels;
        continue;
      }
      if (x < 2 || y < 2 || x >= w - 2 || y >= h - 2 || (x >= 60 && x < 97 && y >= 40 && y < 77)) continue;
      ASSERT_NE(key, ~uint64_t{0}) << x << "," << y;
      const uint32_t winner = uint32_t(key & 0xFFFFFFFFu);
      ASSERT_LT(winner, plane_surfels);
      // The nearest plane surfel is one of the 5x5 neighbourhood's (one per pixel, offset < 0.5).
      double best = 1e9;
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx)
          best = std::min(best, (projected[size_t(y + dy) * w + size_t(x + dx)] - Eigen::Vector2d(x, y)).norm());
      ++plane_pixels;
      nearest += (projected[winner] - Eigen::Vector2d(x, y)).norm() <= best + 1e-4;
    }
  EXPECT_GT(plane_pixels, 10000);
  EXPECT_GE(nearest, plane_pixels * 99 / 100) << nearest << " of " << plane_pixels;
  EXPECT_EQ(patch_wins, patch_pixels);
}

}  // namespace
}  // namespace cofusion::test
