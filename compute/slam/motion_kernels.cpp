#include "slam/motion_kernels.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "embedded_shaders.h"
#include "kernels/image.h"
#include "slam/surfel_model.h"

namespace cofusion::slam {
namespace L = gpu_layout;
using gpu::group_count;

namespace {
uint32_t tiles(int n) { return group_count(static_cast<uint32_t>(n), COFUSION_TILE); }

std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

// Throws unless `buffer` holds at least `bytes`.
void require(const gpu::BufferPtr& buffer, size_t bytes, const std::string& what, const std::string& which) {
  if (!buffer) throw Error(what + ": no " + which + " buffer");
  if (buffer->size() < bytes)
    throw Error(what + ": " + which + " buffer '" + buffer->name() + "' has " + std::to_string(buffer->size()) +
                " bytes, needs " + std::to_string(bytes));
}
}  // namespace

MotionKernels::MotionKernels(gpu::Context& ctx)
    : mask_vertices_(ctx, "mask_vertices", shaders::mask_vertices_comp(), 3, sizeof(L::MaskVerticesParams),
                     (1u << MASK_VERTICES_BINDING_SRC) | (1u << MASK_VERTICES_BINDING_LABELS)),
      motion_residual_(ctx, "motion_residual", shaders::motion_residual_comp(), 6, sizeof(L::MotionResidualParams),
                       (1u << MOTION_RESIDUAL_BINDING_LIVE_VERTEX) | (1u << MOTION_RESIDUAL_BINDING_LIVE_INTENSITY) |
                           (1u << MOTION_RESIDUAL_BINDING_REF_VERTEX) | (1u << MOTION_RESIDUAL_BINDING_REF_NORMAL) |
                           (1u << MOTION_RESIDUAL_BINDING_REF_INTENSITY)) {}

void MotionKernels::mask_vertices(gpu::CommandList& cmd, const gpu::BufferPtr& src_vertex,
                                  const gpu::BufferPtr& dst_vertex, const gpu::BufferPtr& labels, int level_width,
                                  int level_height, int level0_width, int level0_height, int level,
                                  uint32_t keep_mask, const std::optional<PixelRect>& rect) const {
  const std::string what = "mask_vertices (level " + std::to_string(level) + ")";
  if (level < 0 || level > 31) throw Error(what + ": level out of range 0..31");
  if (level0_width <= 0 || level0_height <= 0)
    throw Error(what + ": label map size " + size_text(level0_width, level0_height) + " is empty");
  int w = level0_width, h = level0_height;
  for (int l = 0; l < level; ++l) w = kernels::half_size(w), h = kernels::half_size(h);
  if (w != level_width || h != level_height)
    throw Error(what + ": level size " + size_text(level_width, level_height) + " is not level " +
                std::to_string(level) + " of the " + size_text(level0_width, level0_height) + " label map (" +
                size_text(w, h) + ")");
  const size_t n = size_t(level_width) * size_t(level_height);
  require(src_vertex, n * 16, what, "source vertex");
  require(dst_vertex, n * 16, what, "destination vertex");
  require(labels, size_t(level0_width) * size_t(level0_height) * 4, what, "label");
  const PixelRect r = rect ? rect->clamped(level_width, level_height) : PixelRect::full(level_width, level_height);
  if (r.empty()) return;
  const L::MaskVerticesParams p{uint32_t(level_width), uint32_t(level_height), uint32_t(level0_width),
                                uint32_t(level0_height), uint32_t(level), keep_mask, uint32_t(r.x0), uint32_t(r.y0),
                                uint32_t(r.x1), uint32_t(r.y1)};
  cmd.dispatch(mask_vertices_, {src_vertex, dst_vertex, labels}, p, tiles(r.width()), tiles(r.height()));
}

void MotionKernels::mask_levels(gpu::CommandList& cmd, const std::vector<kernels::FramePyramid::Level>& live,
                                const std::vector<kernels::FramePyramid::Level>& masked, const gpu::BufferPtr& labels,
                                uint32_t keep_mask, const std::optional<PixelRect>& rect_level0) const {
  if (live.empty() || masked.size() != live.size())
    throw Error("mask_levels: " + std::to_string(masked.size()) + " masked levels for " + std::to_string(live.size()) +
                " live levels");
  for (size_t l = 0; l < live.size(); ++l) {
    if (masked[l].vertex == live[l].vertex) throw Error("mask_levels: level " + std::to_string(l) + " masks in place");
    mask_vertices(cmd, live[l].vertex, masked[l].vertex, labels, live[l].width, live[l].height, live[0].width,
                  live[0].height, int(l), keep_mask,
                  rect_level0 ? std::optional(rect_level0->at_level(int(l), live[l].width, live[l].height))
                              : std::nullopt);
  }
}

std::vector<kernels::FramePyramid::Level> MotionKernels::allocate_masked_levels(
    gpu::Context& ctx, const std::vector<kernels::FramePyramid::Level>& live, const std::string& name) {
  std::vector<kernels::FramePyramid::Level> out = live;
  for (size_t l = 0; l < out.size(); ++l)
    out[l].vertex = gpu::Buffer::create(ctx, size_t(out[l].width) * size_t(out[l].height) * 16,
                                        name + " L" + std::to_string(l) + " masked vertex");
  return out;
}

void MotionKernels::residuals(gpu::CommandList& cmd, const kernels::FramePyramid::Level& live,
                              const kernels::FramePyramid::Level& reference, const Eigen::Isometry3d& T_reference_live,
                              const gpu::BufferPtr& out, const std::optional<PixelRect>& rect,
                              double live_intensity_gain) const {
  const std::string what = "MotionKernels::residuals";
  if (live.width != reference.width || live.height != reference.height)
    throw Error(what + ": live " + size_text(live.width, live.height) + " and reference " +
                size_text(reference.width, reference.height) + " differ in size");
  if (!T_reference_live.matrix().allFinite()) throw Error(what + ": T_reference_live is not finite");
  const size_t n = size_t(live.width) * size_t(live.height);
  require(live.vertex, n * 16, what, "live vertex");
  require(live.intensity, n * 4, what, "live intensity");
  require(reference.vertex, n * 16, what, "reference vertex");
  require(reference.normal, n * 16, what, "reference normal");
  require(reference.intensity, n * 4, what, "reference intensity");
  require(out, n * 16, what, "residual");
  L::MotionResidualParams p{};
  to_rows(T_reference_live, p.T_reference_live);
  const Intrinsics& k = live.intrinsics;
  p.fx = float(k.fx), p.fy = float(k.fy), p.cx = float(k.cx), p.cy = float(k.cy);
  p.width = uint32_t(live.width), p.height = uint32_t(live.height);
  p.live_intensity_gain = float(live_intensity_gain);
  const PixelRect r = rect ? rect->clamped(live.width, live.height) : PixelRect::full(live.width, live.height);
  if (r.empty()) return;
  p.rect_x0 = uint32_t(r.x0), p.rect_y0 = uint32_t(r.y0), p.rect_x1 = uint32_t(r.x1), p.rect_y1 = uint32_t(r.y1);
  residuals(cmd, live.vertex, live.intensity, reference.vertex, reference.normal, reference.intensity, out,
                   p);
}

void MotionKernels::residuals(gpu::CommandList& cmd, const gpu::BufferPtr& live_vertex,
                              const gpu::BufferPtr& live_intensity, const gpu::BufferPtr& ref_vertex,
                              const gpu::BufferPtr& ref_normal, const gpu::BufferPtr& ref_intensity,
                              const gpu::BufferPtr& out, const L::MotionResidualParams& p) const {
  const int w = int(std::min(p.rect_x1, p.width)) - int(p.rect_x0), h = int(std::min(p.rect_y1, p.height)) - int(p.rect_y0);
  if (w <= 0 || h <= 0) return;
  cmd.dispatch(motion_residual_, {live_vertex, live_intensity, ref_vertex, ref_normal, ref_intensity, out}, p,
               tiles(w), tiles(h));
}

}  // namespace cofusion::slam
