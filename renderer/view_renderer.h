#pragma once
// Offscreen rendering of surfel models for the viewer and for screenshots, by compute splatting
// (drawing points through the graphics pipeline is 20-80x slower on lavapipe):
//   1. view_splat.comp: every model's surfels are scattered into one depth/index grid with a
//      64-bit atomicMin of (depth << 32 | key index), each covering a square of half-size
//      min(max_footprint_px, projected radius rounded to whole pixels);
//   2. view_resolve.comp, once per model: the pixels that model won get a shaded colour.
// The result is an RGBA8 buffer (R in the low byte), downloaded as an Image. Model buffers are
// only read. render_reference() is the same arithmetic on the CPU, for tests.
#include <Eigen/Geometry>
#include <cstdint>
#include <span>
#include <vector>

#include "common/intrinsics.h"
#include "common/surfel_cloud.h"
#include "gpu/pipeline.h"
#include "gpu/stream.h"
#include "renderer/image.h"

namespace cofusion::renderer {

enum class ColourMode : uint32_t {
  Rgb = 0,         // the surfels' fused colour, shaded
  ModelLabel = 1,  // a fixed palette colour per model id, shaded
  Normal = 2,      // view-frame normal as (n + 1) / 2, unshaded
  Confidence = 3,  // confidence through a jet-like colour map, shaded
};
const char* to_string(ColourMode mode);

// The virtual camera: a pinhole with its image size and its pose in the world.
struct VirtualCamera {
  Intrinsics intrinsics;  // also the image size
  Eigen::Isometry3d T_world_view = Eigen::Isometry3d::Identity();  // view frame: x right, y down, z forward
};

struct RenderParams {
  ColourMode colour_mode = ColourMode::Rgb;
  unsigned max_footprint_px = 4;       // cap of a surfel's square half-size, pixels (0 = one pixel)
  float min_confidence = 0.0f;         // surfels with less accumulated weight are hidden
  float confidence_max = 10.0f;        // confidence shown at the top of the colour map
  float ambient = 0.35f;               // shading: ambient + (1 - ambient) * |cos(normal, view ray)|, in [0, 1]
  float near_m = 0.01f;                // surfels nearer to the view than this are clipped, metres
  uint32_t background_rgba8 = 0xFF302820u;  // R in the low byte
};

// A model as the renderer reads it: a GPU buffer of `count` Surfels in the model frame.
struct ModelView {
  gpu::BufferPtr surfels;
  unsigned count = 0;
  int model_id = 0;
  Eigen::Isometry3d T_world_model = Eigen::Isometry3d::Identity();
};

// Fixed palette colour of a model id (label mode and bounding boxes); id 0 is grey.
uint32_t model_colour(int model_id);

class ViewRenderer {
 public:
  explicit ViewRenderer(gpu::Context& ctx);

  // Records the splat and resolve passes into `cmd`; `image` (uint per pixel, at least w*h) ends up
  // holding the RGBA8 picture. Throws cofusion::Error on implausible intrinsics, a too-small
  // image buffer, a model buffer smaller than its count, or more than 2^32-1 surfels in all.
  void record(gpu::CommandList& cmd, std::span<const ModelView> models, const VirtualCamera& camera,
              const RenderParams& params, const gpu::BufferPtr& image) const;

  // Synchronous: records, submits, waits and downloads.
  Image render(gpu::Stream& stream, std::span<const ModelView> models, const VirtualCamera& camera,
               const RenderParams& params) const;
  // Host clouds: uploaded into temporary buffers for this call.
  Image render(gpu::Stream& stream, std::span<const SurfelCloud> clouds, const VirtualCamera& camera,
               const RenderParams& params) const;

  // Buffer for an image of this size (a new one when the size changes), for callers that keep
  // the picture on the device (e.g. the window copies it to the swapchain).
  gpu::BufferPtr image_buffer(int width, int height) const;

 private:
  gpu::BufferPtr depth_index_for(int width, int height) const;
  gpu::Context& ctx_;
  gpu::ComputePipeline splat_;
  gpu::ComputePipeline resolve_;
  mutable gpu::BufferPtr depth_index_;
  mutable gpu::BufferPtr image_;
};

// CPU reference of ViewRenderer::render (same splat order semantics: nearest depth, then lowest
// key index; same shading), single-threaded.
Image render_reference(std::span<const SurfelCloud> clouds, const VirtualCamera& camera, const RenderParams& params);

// Pose of a view at eye_world looking at target_world (view frame: z forward, x right, y down,
// with -y as close to up_world as possible). Throws cofusion::Error when eye == target or the
// view direction is parallel to up_world.
Eigen::Isometry3d look_at(const Eigen::Vector3d& eye_world, const Eigen::Vector3d& target_world,
                          const Eigen::Vector3d& up_world);

// Row-major float 3x4 of a rigid transform, as the shaders take it.
void to_rows_3x4(const Eigen::Isometry3d& T, float out[12]);

}  // namespace cofusion::renderer
