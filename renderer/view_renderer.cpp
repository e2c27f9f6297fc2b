#include "renderer/view_renderer.h"

#include <algorithm>
#include <array>
#include <limits>
#include <string>

#include "common/error.h"
#include "embedded_shaders.h"
#include "shared/host_device.h"

namespace cofusion::renderer {

using gpu_layout::ViewResolveParams;
using gpu_layout::ViewSplatParams;

const char* to_string(ColourMode mode) {
  switch (mode) {
    case ColourMode::Rgb: return "rgb";
    case ColourMode::ModelLabel: return "label";
    case ColourMode::Normal: return "normal";
    default: return "confidence";
  }
}

uint32_t model_colour(int model_id) {
  // Distinct, saturated colours (Tableau-like); the background model 0 is neutral grey.
  static constexpr std::array<uint32_t, 10> palette{
      rgba8(200, 200, 200), rgba8(31, 119, 180), rgba8(255, 127, 14), rgba8(44, 160, 44), rgba8(214, 39, 40),
      rgba8(148, 103, 189), rgba8(140, 86, 75), rgba8(227, 119, 194), rgba8(188, 189, 34), rgba8(23, 190, 207)};
  if (model_id <= 0) return palette[0];
  return palette[1 + static_cast<size_t>(model_id - 1) % (palette.size() - 1)];
}

void to_rows_3x4(const Eigen::Isometry3d& T, float out[12]) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out[r * 4 + c] = static_cast<float>(T.linear()(r, c));
    out[r * 4 + 3] = static_cast<float>(T.translation()(r));
  }
}

Eigen::Isometry3d look_at(const Eigen::Vector3d& eye_world, const Eigen::Vector3d& target_world,
                          const Eigen::Vector3d& up_world) {
  const Eigen::Vector3d forward = target_world - eye_world;
  if (!(forward.norm() > 1e-12)) throw Error("look_at: eye and target coincide");
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d x = (-up_world).cross(z);  // right = down x forward
  if (!(x.norm() > 1e-9)) throw Error("look_at: view direction parallel to the up vector");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x.normalized();
  T.linear().col(2) = z;
  T.linear().col(1) = z.cross(T.linear().col(0));
  T.translation() = eye_world;
  return T;
}

ViewRenderer::ViewRenderer(gpu::Context& ctx)
    : ctx_(ctx),
      splat_(ctx, "view_splat", shaders::view_splat_comp(), 2, sizeof(ViewSplatParams), 1u << VIEW_SPLAT_BINDING_SURFELS),
      resolve_(ctx, "view_resolve", shaders::view_resolve_comp(), 3, sizeof(ViewResolveParams),
               (1u << VIEW_RESOLVE_BINDING_SURFELS) | (1u << VIEW_RESOLVE_BINDING_DEPTH_INDEX)) {}

gpu::BufferPtr ViewRenderer::depth_index_for(int width, int height) const {
  const size_t bytes = static_cast<size_t>(width) * height * sizeof(uint64_t);
  if (!depth_index_ || depth_index_->size() != bytes) depth_index_ = gpu::Buffer::create(ctx_, bytes, "view depth/index");
  return depth_index_;
}

gpu::BufferPtr ViewRenderer::image_buffer(int width, int height) const {
  const size_t bytes = static_cast<size_t>(width) * height * sizeof(uint32_t);
  if (!image_ || image_->size() != bytes) image_ = gpu::Buffer::create(ctx_, bytes, "view image");
  return image_;
}

namespace {
void check_camera(const VirtualCamera& camera) {
  if (!camera.intrinsics.plausible())
    throw Error("view renderer: implausible virtual camera intrinsics (" + camera.intrinsics.to_string() + ")");
}
}  // namespace

void ViewRenderer::record(gpu::CommandList& cmd, std::span<const ModelView> models, const VirtualCamera& camera,
                          const RenderParams& params, const gpu::BufferPtr& image) const {
  check_camera(camera);
  const auto& K = camera.intrinsics;
  const uint32_t w = static_cast<uint32_t>(K.width), h = static_cast<uint32_t>(K.height);
  if (!image || image->size() < static_cast<size_t>(w) * h * sizeof(uint32_t))
    throw Error("view renderer: image buffer smaller than " + std::to_string(w) + "x" + std::to_string(h) + " RGBA8");
  uint64_t total = 0;
  for (const auto& m : models) {
    if (m.count > 0 && (!m.surfels || m.surfels->size() < static_cast<size_t>(m.count) * sizeof(Surfel)))
      throw Error("view renderer: model " + std::to_string(m.model_id) + " has a buffer smaller than its " +
                  std::to_string(m.count) + " surfels");
    total += m.count;
  }
  // All ones is the empty key, so the largest key index is 2^32 - 2.
  if (total >= std::numeric_limits<uint32_t>::max())
    throw Error("view renderer: " + std::to_string(total) + " surfels in all, more than one frame can index");

  const auto grid = depth_index_for(K.width, K.height);
  cmd.fill(grid, 0xFFFFFFFFu);
  cmd.fill(image, params.background_rgba8);
  cmd.barrier();
  const Eigen::Isometry3d T_view_world = camera.T_world_view.inverse();
  uint32_t base = 0;
  for (const auto& m : models) {
    if (m.count == 0) continue;
    ViewSplatParams p{};
    to_rows_3x4(T_view_world * m.T_world_model, p.T_view_model);
    p.fx = static_cast<float>(K.fx);
    p.fy = static_cast<float>(K.fy);
    p.cx = static_cast<float>(K.cx);
    p.cy = static_cast<float>(K.cy);
    p.width = w;
    p.height = h;
    p.surfel_count = m.count;
    p.index_base = base;
    p.min_confidence = params.min_confidence;
    p.max_footprint_px = params.max_footprint_px;
    p.near_m = params.near_m;
    cmd.dispatch(splat_, {m.surfels, grid}, p, gpu::group_count(m.count, 128));
    base += m.count;
  }
  cmd.barrier();
  base = 0;
  for (const auto& m : models) {
    if (m.count == 0) continue;
    ViewResolveParams p{};
    to_rows_3x4(T_view_world * m.T_world_model, p.T_view_model);
    p.width = w;
    p.height = h;
    p.surfel_count = m.count;
    p.index_base = base;
    p.colour_mode = static_cast<uint32_t>(params.colour_mode);
    p.label_rgba8 = model_colour(m.model_id);
    p.confidence_max = params.confidence_max;
    p.ambient = params.ambient;
    // Models win disjoint pixel sets, so their resolves need no barrier between them.
    cmd.dispatch(resolve_, {m.surfels, grid, image}, p, gpu::group_count(w, COFUSION_TILE),
                 gpu::group_count(h, COFUSION_TILE));
    base += m.count;
  }
  cmd.barrier();
}

Image ViewRenderer::render(gpu::Stream& stream, std::span<const ModelView> models, const VirtualCamera& camera,
                           const RenderParams& params) const {
  check_camera(camera);
  const auto image = image_buffer(camera.intrinsics.width, camera.intrinsics.height);
  stream.run([&](gpu::CommandList& cmd) { record(cmd, models, camera, params, image); });
  Image out(camera.intrinsics.width, camera.intrinsics.height);
  stream.download(image, out.rgba.data(), out.rgba.size() * sizeof(uint32_t));
  return out;
}

Image ViewRenderer::render(gpu::Stream& stream, std::span<const SurfelCloud> clouds, const VirtualCamera& camera,
                           const RenderParams& params) const {
  std::vector<ModelView> models;
  for (const auto& c : clouds) {
    ModelView m;
    m.count = static_cast<unsigned>(c.surfels.size());
    m.model_id = c.model_id;
    m.T_world_model = c.T_world_model;
    if (m.count > 0) {
      m.surfels = gpu::Buffer::create(ctx_, c.surfels.size() * sizeof(Surfel), "view model " + std::to_string(c.model_id));
      stream.upload(m.surfels, std::span<const Surfel>(c.surfels));
    }
    models.push_back(std::move(m));
  }
  return render(stream, std::span<const ModelView>(models), camera, params);
}

}  // namespace cofusion::renderer
