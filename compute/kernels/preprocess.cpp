#include "kernels/preprocess.h"

#include "kernels/image.h"

#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "embedded_shaders.h"
#include "shared/host_device.h"

namespace cofusion::kernels {
namespace L = gpu_layout;
using gpu::group_count;

namespace {
uint32_t groups(int n) { return group_count(static_cast<uint32_t>(n), COFUSION_TILE); }
size_t pixels(int w, int h) { return static_cast<size_t>(w) * static_cast<size_t>(h); }
}  // namespace

FramePyramid FramePyramid::allocate(gpu::Context& ctx, const Intrinsics& intrinsics, int level_count,
                                    const std::string& name) {
  if (!intrinsics.plausible()) throw Error(name + ": implausible intrinsics " + intrinsics.to_string());
  if (level_count < 1) throw Error(name + ": pyramid needs at least one level");
  FramePyramid f;
  const size_t n0 = pixels(intrinsics.width, intrinsics.height);
  f.raw_depth = gpu::Buffer::create(ctx, n0 * sizeof(uint16_t), name + " raw depth");
  f.rgb = gpu::Buffer::create(ctx, n0 * 3, name + " rgb");
  f.depth_raw_m = gpu::Buffer::create(ctx, n0 * sizeof(float), name + " depth before filter");
  for (int l = 0; l < level_count; ++l) {
    Level level;
    level.intrinsics = intrinsics.at_level(l);
    level.width = level.intrinsics.width;
    level.height = level.intrinsics.height;
    const size_t n = pixels(level.width, level.height);
    const std::string prefix = name + " L" + std::to_string(l) + " ";
    level.depth_m = gpu::Buffer::create(ctx, n * sizeof(float), prefix + "depth");
    level.intensity = gpu::Buffer::create(ctx, n * sizeof(float), prefix + "intensity");
    level.vertex = gpu::Buffer::create(ctx, n * 4 * sizeof(float), prefix + "vertex");
    level.normal = gpu::Buffer::create(ctx, n * 4 * sizeof(float), prefix + "normal");
    level.gradient = gpu::Buffer::create(ctx, n * 2 * sizeof(float), prefix + "gradient");
    f.levels.push_back(std::move(level));
  }
  return f;
}

namespace {
// Depth in upload units; NaN, negative and out-of-range readings become "no reading". In
// parallel: it is on the frame's critical path, before anything else starts.
std::vector<uint16_t> depth_units(const float* depth_m, size_t n) {
  std::vector<uint16_t> units(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const float u = depth_m[i] / FramePyramid::kUploadMetresPerUnit;
      units[i] = (u >= 0.5f && u < 65535.0f) ? static_cast<uint16_t>(std::lround(u)) : 0;
    }
  });
  return units;
}
}  // namespace

void FramePyramid::upload(gpu::Stream& stream, const float* depth_m, const uint8_t* rgb8) const {
  const size_t n = pixels(levels.at(0).width, levels.at(0).height);
  const std::vector<uint16_t> units = depth_units(depth_m, n);
  stream.upload(raw_depth, units.data(), n * sizeof(uint16_t));
  stream.upload(rgb, rgb8, n * 3);
}

void FramePyramid::record_upload(gpu::Context& ctx, gpu::CommandList& cmd, const float* depth_m, const uint8_t* rgb8) {
  const size_t n = pixels(levels.at(0).width, levels.at(0).height);
  const std::vector<uint16_t> units = depth_units(depth_m, n);
  gpu::record_upload(ctx, cmd, raw_depth, units.data(), n * sizeof(uint16_t), 0, raw_depth_staging);
  gpu::record_upload(ctx, cmd, rgb, rgb8, n * 3, 0, rgb_staging);
}

Preprocessor::Preprocessor(gpu::Context& ctx)
    : depth_to_metres_(ctx, "depth_to_metres", shaders::depth_to_metres_comp(), 2, sizeof(L::DepthToMetresParams),
                       1u << DEPTH_TO_METRES_BINDING_RAW),
      bilateral_(ctx, "bilateral_depth", shaders::bilateral_depth_comp(), 2, sizeof(L::BilateralParams),
                 1u << BILATERAL_BINDING_SRC),
      depth_pyramid_(ctx, "depth_pyramid", shaders::depth_pyramid_comp(), 2, sizeof(L::DownsampleParams),
                     1u << DOWNSAMPLE_BINDING_SRC),
      intensity_pyramid_(ctx, "intensity_pyramid", shaders::intensity_pyramid_comp(), 2, sizeof(L::DownsampleParams),
                         1u << DOWNSAMPLE_BINDING_SRC),
      rgb_to_intensity_(ctx, "rgb_to_intensity", shaders::rgb_to_intensity_comp(), 2, sizeof(L::IntensityParams),
                        1u << INTENSITY_BINDING_RGB),
      vertex_normal_(ctx, "vertex_normal_map", shaders::vertex_normal_map_comp(), 3, sizeof(L::VertexNormalParams),
                    1u << VERTEX_NORMAL_BINDING_DEPTH),
      gradient_(ctx, "intensity_gradient", shaders::intensity_gradient_comp(), 2, sizeof(L::GradientParams),
                1u << GRADIENT_BINDING_INTENSITY) {}

void Preprocessor::depth_to_metres(gpu::CommandList& cmd, const gpu::BufferPtr& raw, const gpu::BufferPtr& depth_m,
                                   int width, int height, float metres_per_unit, float min_depth_m,
                                   float max_depth_m) const {
  const L::DepthToMetresParams p{static_cast<uint32_t>(width), static_cast<uint32_t>(height), metres_per_unit,
                                 min_depth_m, max_depth_m};
  cmd.dispatch(depth_to_metres_, {raw, depth_m}, p, groups(width), groups(height));
}

void Preprocessor::bilateral_depth(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst,
                                   int width, int height, int radius_px, float sigma_space_px,
                                   float sigma_depth_m) const {
  const L::BilateralParams p{static_cast<uint32_t>(width), static_cast<uint32_t>(height), radius_px, sigma_space_px,
                             sigma_depth_m};
  cmd.dispatch(bilateral_, {src, dst}, p, groups(width), groups(height));
}

void Preprocessor::downsample_depth(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst,
                                    int src_width, int src_height, float max_depth_diff_m) const {
  const L::DownsampleParams p{static_cast<uint32_t>(src_width), static_cast<uint32_t>(src_height),
                              static_cast<uint32_t>(half_size(src_width)), static_cast<uint32_t>(half_size(src_height)),
                              max_depth_diff_m};
  cmd.dispatch(depth_pyramid_, {src, dst}, p, groups(half_size(src_width)), groups(half_size(src_height)));
}

void Preprocessor::downsample_intensity(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst,
                                        int src_width, int src_height) const {
  const L::DownsampleParams p{static_cast<uint32_t>(src_width), static_cast<uint32_t>(src_height),
                              static_cast<uint32_t>(half_size(src_width)), static_cast<uint32_t>(half_size(src_height)),
                              0.0f};
  cmd.dispatch(intensity_pyramid_, {src, dst}, p, groups(half_size(src_width)), groups(half_size(src_height)));
}

void Preprocessor::rgb_to_intensity(gpu::CommandList& cmd, const gpu::BufferPtr& rgb, const gpu::BufferPtr& intensity,
                                    int width, int height) const {
  const L::IntensityParams p{static_cast<uint32_t>(width), static_cast<uint32_t>(height)};
  cmd.dispatch(rgb_to_intensity_, {rgb, intensity}, p, groups(width), groups(height));
}

void Preprocessor::vertex_normal_map(gpu::CommandList& cmd, const gpu::BufferPtr& depth_m, const gpu::BufferPtr& vertex,
                                     const gpu::BufferPtr& normal, const Intrinsics& k) const {
  const L::VertexNormalParams p{static_cast<uint32_t>(k.width), static_cast<uint32_t>(k.height),
                                static_cast<float>(k.fx),     static_cast<float>(k.fy),
                                static_cast<float>(k.cx),     static_cast<float>(k.cy)};
  cmd.dispatch(vertex_normal_, {depth_m, vertex, normal}, p, groups(k.width), groups(k.height));
}

void Preprocessor::intensity_gradient(gpu::CommandList& cmd, const gpu::BufferPtr& intensity,
                                      const gpu::BufferPtr& gradient, int width, int height,
                                      const std::optional<PixelRect>& rect) const {
  const PixelRect r = rect ? rect->clamped(width, height) : PixelRect::full(width, height);
  if (r.empty()) return;
  const L::GradientParams p{static_cast<uint32_t>(width), static_cast<uint32_t>(height), uint32_t(r.x0), uint32_t(r.y0),
                            uint32_t(r.x1),               uint32_t(r.y1)};
  cmd.dispatch(gradient_, {intensity, gradient}, p, groups(r.width()), groups(r.height()));
}

void Preprocessor::record_frame(gpu::CommandList& cmd, FramePyramid& f, float metres_per_unit,
                                const PreprocessParams& params) const {
  auto& l0 = f.levels[0];
  // Level 0: metric depth (filtered) and intensity are independent, so no barrier between them.
  depth_to_metres(cmd, f.raw_depth, params.bilateral ? f.depth_raw_m : l0.depth_m, l0.width, l0.height,
                  metres_per_unit, params.min_depth_m, params.max_depth_m);
  rgb_to_intensity(cmd, f.rgb, l0.intensity, l0.width, l0.height);
  cmd.barrier();
  if (params.bilateral) {
    bilateral_depth(cmd, f.depth_raw_m, l0.depth_m, l0.width, l0.height, params.bilateral_radius_px,
                    params.bilateral_sigma_space_px, params.bilateral_sigma_depth_m);
    cmd.barrier();
  }
  for (size_t l = 1; l < f.levels.size(); ++l) {
    const auto& src = f.levels[l - 1];
    downsample_depth(cmd, src.depth_m, f.levels[l].depth_m, src.width, src.height, params.pyramid_max_depth_diff_m);
    downsample_intensity(cmd, src.intensity, f.levels[l].intensity, src.width, src.height);
    cmd.barrier();
  }
  for (auto& level : f.levels) {
    vertex_normal_map(cmd, level.depth_m, level.vertex, level.normal, level.intrinsics);
    if (params.live_gradients) intensity_gradient(cmd, level.intensity, level.gradient, level.width, level.height);
  }
  cmd.barrier();
}

}  // namespace cofusion::kernels
