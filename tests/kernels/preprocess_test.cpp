// Each preprocessing kernel against its CPU reference (compute/kernels/preprocess_reference.h) on
// the Vulkan device, over edge sizes: 1x1, odd sizes, 160x120 and 640x480. Tolerances are stated
// per kernel: float rounding differs between the CPU and the driver (fused multiply-adds, exp).
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <random>

#include "kernels/preprocess.h"
#include "kernels/preprocess_reference.h"
#include "support/gpu_fixture.h"

namespace cofusion::test {
namespace {
using kernels::Image;
namespace ref = kernels::reference;

struct Size {
  int width, height;
};
const Size kSizes[] = {{1, 1}, {2, 3}, {37, 23}, {160, 120}, {640, 480}};

std::string name(Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

// A depth image with planes at different depths (edges), a slanted floor, a sphere, and holes.
Image<float> make_depth(Size s, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-0.004f, 0.004f), unit(0.0f, 1.0f);
  Image<float> d(s.width, s.height);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x) {
      const float u = (x + 0.5f) / s.width, v = (y + 0.5f) / s.height;
      float z = 2.5f - 1.2f * v;                                      // slanted floor / wall
      if (u > 0.6f && v < 0.5f) z = 1.1f;                              // a box in front: depth edge
      const float du = u - 0.3f, dv = v - 0.4f, r2 = du * du + dv * dv;  // a sphere
      if (r2 < 0.02f) z = 1.6f - std::sqrt(0.02f - r2);
      z += noise(rng);
      if (unit(rng) < 0.05f) z = 0.0f;  // holes
      d.at(x, y) = z;
    }
  return d;
}

std::vector<uint8_t> make_rgb(Size s, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> byte(0, 255);
  std::vector<uint8_t> rgb(static_cast<size_t>(s.width) * s.height * 3);
  for (auto& b : rgb) b = static_cast<uint8_t>(byte(rng));
  return rgb;
}

Intrinsics intrinsics_for(Size s) {
  Intrinsics k;
  k.width = s.width;
  k.height = s.height;
  k.fx = k.fy = 525.0 * s.width / 640.0;
  k.cx = (s.width - 1) / 2.0 + 0.3;
  k.cy = (s.height - 1) / 2.0 - 0.2;
  return k;
}

class PreprocessKernels : public GpuTest {
 protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (!pre_) pre_ = std::make_unique<kernels::Preprocessor>(ctx());
  }
  static void TearDownTestSuite() {
    pre_.reset();
    GpuTest::TearDownTestSuite();
  }
  template <typename T>
  gpu::BufferPtr upload(const Image<T>& image) {
    auto b = gpu::Buffer::create(ctx(), image.bytes(), "input");
    stream().upload(b, image.pixels.data(), image.bytes());
    return b;
  }
  template <typename T>
  gpu::BufferPtr output(int w, int h) {
    return gpu::Buffer::create(ctx(), static_cast<size_t>(w) * h * sizeof(T), "output");
  }
  template <typename T>
  Image<T> download(const gpu::BufferPtr& b, int w, int h) {
    Image<T> out(w, h);
    stream().download(b, out.pixels.data(), out.bytes());
    return out;
  }
  static std::unique_ptr<kernels::Preprocessor> pre_;
};
std::unique_ptr<kernels::Preprocessor> PreprocessKernels::pre_;

void expect_near_images(const Image<float>& gpu, const Image<float>& cpu, float abs_tol, float rel_tol,
                        const std::string& what) {
  ASSERT_EQ(gpu.size(), cpu.size());
  int bad = 0;
  for (size_t i = 0; i < cpu.size(); ++i) {
    const float tol = abs_tol + rel_tol * std::abs(cpu.pixels[i]);
    if (!(std::abs(gpu.pixels[i] - cpu.pixels[i]) <= tol) && ++bad <= 5) {
      ADD_FAILURE() << what << " pixel " << i << ": gpu " << gpu.pixels[i] << " cpu " << cpu.pixels[i];
    }
  }
  EXPECT_EQ(bad, 0) << what;
}

TEST_F(PreprocessKernels, DepthToMetresMatchesReference) {
  for (Size s : kSizes) {
    std::mt19937 rng(1);
    std::uniform_int_distribution<int> units(0, 40000);
    Image<uint16_t> raw(s.width, s.height);
    for (auto& v : raw.pixels) v = static_cast<uint16_t>(units(rng) < 2000 ? 0 : units(rng));
    auto raw_buf = upload(raw);
    auto out = output<float>(s.width, s.height);
    stream().run([&](gpu::CommandList& c) { pre_->depth_to_metres(c, raw_buf, out, s.width, s.height, 1.0f / 5000, 0.3f, 5.0f); });
    // Tolerance: one multiply on both sides -> exact up to 1 ulp.
    expect_near_images(download<float>(out, s.width, s.height), ref::depth_to_metres(raw, 1.0f / 5000, 0.3f, 5.0f), 0,
                       1e-7f, "depth_to_metres " + name(s));
  }
}

// Radius 1 (the default 3x3 window) runs the kernel's unrolled path, 2 its general loop.
TEST_F(PreprocessKernels, BilateralFilterMatchesReference) {
  for (int radius_px : {1, 2}) {
    for (Size s : kSizes) {
      const auto depth = make_depth(s, 2);
      auto in = upload(depth);
      auto out = output<float>(s.width, s.height);
      stream().run([&](gpu::CommandList& c) { pre_->bilateral_depth(c, in, out, s.width, s.height, radius_px, 2.0f, 0.03f); });
      // Tolerance 2e-6 relative: float accumulation of <= 25 weighted samples vs double on the CPU.
      expect_near_images(download<float>(out, s.width, s.height), ref::bilateral_depth(depth, radius_px, 2.0f, 0.03f),
                         1e-6f, 2e-6f, "bilateral radius " + std::to_string(radius_px) + " " + name(s));
    }
  }
}

TEST_F(PreprocessKernels, DepthAndIntensityDownsamplingMatchReference) {
  for (Size s : kSizes) {
    const auto depth = make_depth(s, 3);
    const auto rgb = make_rgb(s, 3);
    const auto intensity = ref::rgb_to_intensity(rgb.data(), s.width, s.height);
    auto d_in = upload(depth), i_in = upload(intensity);
    const int w2 = kernels::half_size(s.width), h2 = kernels::half_size(s.height);
    auto d_out = output<float>(w2, h2), i_out = output<float>(w2, h2);
    stream().run([&](gpu::CommandList& c) {
      pre_->downsample_depth(c, d_in, d_out, s.width, s.height, 0.1f);
      pre_->downsample_intensity(c, i_in, i_out, s.width, s.height);
    });
    // Tolerance 1e-6 relative: a sum of at most 4 values and one division.
    expect_near_images(download<float>(d_out, w2, h2), ref::downsample_depth(depth, 0.1f), 0, 1e-6f,
                       "depth pyramid " + name(s));
    expect_near_images(download<float>(i_out, w2, h2), ref::downsample_intensity(intensity), 1e-4f, 1e-6f,
                       "intensity pyramid " + name(s));
  }
}

TEST_F(PreprocessKernels, IntensityMatchesReference) {
  for (Size s : kSizes) {
    const auto rgb = make_rgb(s, 4);
    auto in = gpu::Buffer::create(ctx(), rgb.size(), "rgb");
    stream().upload(in, rgb.data(), rgb.size());
    auto out = output<float>(s.width, s.height);
    stream().run([&](gpu::CommandList& c) { pre_->rgb_to_intensity(c, in, out, s.width, s.height); });
    // Tolerance 1e-4 absolute on [0, 255]: the driver may divide by 3 as a multiply by 1/3.
    expect_near_images(download<float>(out, s.width, s.height), ref::rgb_to_intensity(rgb.data(), s.width, s.height),
                       1e-4f, 0, "intensity " + name(s));
  }
}

TEST_F(PreprocessKernels, VertexAndNormalMapsMatchReference) {
  for (Size s : kSizes) {
    const auto depth = make_depth(s, 5);
    const Intrinsics k = intrinsics_for(s);
    auto in = upload(depth);
    auto v_out = output<glm::vec4>(s.width, s.height), n_out = output<glm::vec4>(s.width, s.height);
    stream().run([&](gpu::CommandList& c) { pre_->vertex_normal_map(c, in, v_out, n_out, k); });
    Image<glm::vec4> v_ref, n_ref;
    ref::vertex_normal_map(depth, k, v_ref, n_ref);
    const auto v_gpu = download<glm::vec4>(v_out, s.width, s.height);
    const auto n_gpu = download<glm::vec4>(n_out, s.width, s.height);
    int bad = 0, valid_normals = 0;
    for (size_t i = 0; i < v_ref.size(); ++i) {
      // Validity must agree exactly; vertices within 1e-6 relative (3 float ops), normals within
      // 1e-4 (a normalised cross product of small differences amplifies rounding).
      const bool ok = v_gpu.pixels[i].w == v_ref.pixels[i].w && n_gpu.pixels[i].w == n_ref.pixels[i].w &&
                      glm::length(glm::vec3(v_gpu.pixels[i] - v_ref.pixels[i])) <= 1e-6f * (1 + v_ref.pixels[i].z) &&
                      glm::length(glm::vec3(n_gpu.pixels[i] - n_ref.pixels[i])) <= 1e-4f;
      valid_normals += n_ref.pixels[i].w > 0;
      if (!ok && ++bad <= 5) {
        ADD_FAILURE() << name(s) << " pixel " << i;
      }
    }
    EXPECT_EQ(bad, 0) << name(s);
    if (s.width >= 160) {
      EXPECT_GT(valid_normals, static_cast<int>(v_ref.size() / 2)) << "test data has too few normals";
    }
  }
}

TEST_F(PreprocessKernels, IntensityGradientMatchesReference) {
  for (Size s : kSizes) {
    const auto rgb = make_rgb(s, 6);
    const auto intensity = ref::rgb_to_intensity(rgb.data(), s.width, s.height);
    auto in = upload(intensity);
    auto out = output<glm::vec2>(s.width, s.height);
    stream().run([&](gpu::CommandList& c) { pre_->intensity_gradient(c, in, out, s.width, s.height); });
    const auto g_gpu = download<glm::vec2>(out, s.width, s.height);
    const auto g_ref = ref::intensity_gradient(intensity);
    int bad = 0;
    // Tolerance 1e-3 absolute on gradients of [0, 255] intensities (8 terms, any summation order).
    for (size_t i = 0; i < g_ref.size(); ++i)
      if (glm::length(g_gpu.pixels[i] - g_ref.pixels[i]) > 1e-3f && ++bad <= 5) {
        ADD_FAILURE() << name(s) << " pixel " << i;
      }
    EXPECT_EQ(bad, 0) << name(s);
  }
}

// The whole chain as the pipeline records it, against the chain of references.
TEST_F(PreprocessKernels, WholeFrameChainMatchesReferenceChain) {
  for (Size s : kSizes) {
    const Intrinsics k = intrinsics_for(s);
    const auto depth = make_depth(s, 7);
    Image<uint16_t> raw(s.width, s.height);
    for (size_t i = 0; i < raw.size(); ++i) raw.pixels[i] = static_cast<uint16_t>(std::lround(depth.pixels[i] * 5000.0f));
    const auto rgb = make_rgb(s, 7);
    kernels::PreprocessParams params;
    params.live_gradients = true;
    params.bilateral_radius_px = 2;
    auto frame = kernels::FramePyramid::allocate(ctx(), k, params.pyramid_levels, "test frame");
    stream().upload(frame.raw_depth, raw.pixels.data(), raw.bytes());
    stream().upload(frame.rgb, rgb.data(), rgb.size());
    stream().run([&](gpu::CommandList& c) { pre_->record_frame(c, frame, 1.0f / 5000, params); });

    Image<float> d = ref::bilateral_depth(ref::depth_to_metres(raw, 1.0f / 5000, params.min_depth_m, params.max_depth_m),
                                          params.bilateral_radius_px, params.bilateral_sigma_space_px,
                                          params.bilateral_sigma_depth_m);
    Image<float> in = ref::rgb_to_intensity(rgb.data(), s.width, s.height);
    for (int l = 0; l < params.pyramid_levels; ++l) {
      if (l > 0) {
        d = ref::downsample_depth(d, params.pyramid_max_depth_diff_m);
        in = ref::downsample_intensity(in);
      }
      const auto& level = frame.levels[l];
      ASSERT_EQ(level.width, d.width);
      ASSERT_EQ(level.height, d.height);
      expect_near_images(download<float>(level.depth_m, d.width, d.height), d, 1e-6f, 2e-6f,
                         "chain depth L" + std::to_string(l) + " " + name(s));
      expect_near_images(download<float>(level.intensity, d.width, d.height), in, 1e-4f, 1e-6f,
                         "chain intensity L" + std::to_string(l) + " " + name(s));
      Image<glm::vec4> v_ref, n_ref;
      ref::vertex_normal_map(d, level.intrinsics, v_ref, n_ref);
      const auto v_gpu = download<glm::vec4>(level.vertex, d.width, d.height);
      int bad = 0;
      for (size_t i = 0; i < v_ref.size(); ++i)
        if (v_gpu.pixels[i].w != v_ref.pixels[i].w ||
            glm::length(glm::vec3(v_gpu.pixels[i] - v_ref.pixels[i])) > 1e-5f * (1 + v_ref.pixels[i].z))
          ++bad;
      EXPECT_EQ(bad, 0) << "chain vertices L" << l << " " << name(s);
      const auto g_ref = ref::intensity_gradient(in);
      const auto g_gpu = download<glm::vec2>(level.gradient, d.width, d.height);
      bad = 0;
      for (size_t i = 0; i < g_ref.size(); ++i) bad += glm::length(g_gpu.pixels[i] - g_ref.pixels[i]) > 1e-3f;
      EXPECT_EQ(bad, 0) << "chain gradients L" << l << " " << name(s);
    }
  }
}

TEST(Intrinsics, PyramidLevelsHalveFocalLengthAndShiftPrincipalPoint) {
  Intrinsics k{.fx = 500, .fy = 400, .cx = 319.5, .cy = 239.5, .width = 640, .height = 480};
  const auto k2 = k.at_level(2);
  EXPECT_DOUBLE_EQ(k2.fx, 125);
  EXPECT_DOUBLE_EQ(k2.fy, 100);
  // Pixel centres: level-1 pixel x covers level-0 x' = 2x + 0.5, so the image centre stays put.
  EXPECT_DOUBLE_EQ(k2.cx, 79.5);
  EXPECT_DOUBLE_EQ(k2.cy, 59.5);
  EXPECT_EQ(k2.width, 160);
  const Intrinsics one_pixel{.width = 1, .height = 1};
  EXPECT_EQ(one_pixel.at_level(3).width, 1);
}

}  // namespace
}  // namespace cofusion::test
