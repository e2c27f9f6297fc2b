#pragma once
// GPU preprocessing of an RGB-D frame into the inputs of tracking: metric depth (cut off and
// bilateral-filtered), 4-level pyramids of depth and intensity, vertex and normal maps and
// intensity gradients at every level. Each step is one kernel (shaders/*.comp) with a CPU
// reference in preprocess_reference.h.
#include <cstdint>
#include <optional>
#include <vector>

#include "common/intrinsics.h"
#include "common/pixel_rect.h"
#include "gpu/stream.h"
#include "kernels/preprocess_params.h"

namespace cofusion::kernels {

// GPU buffers of one frame. Level 0 is the input resolution.
struct FramePyramid {
  struct Level {
    int width = 0;
    int height = 0;
    Intrinsics intrinsics;
    gpu::BufferPtr depth_m;    // float[]; level 0: after the bilateral filter
    gpu::BufferPtr intensity;  // float[] in [0, 255]
    gpu::BufferPtr vertex;     // vec4[] camera frame, metres
    gpu::BufferPtr normal;     // vec4[]
    gpu::BufferPtr gradient;   // vec2[] dI/dx, dI/dy (live frames: only with PreprocessParams::live_gradients)
  };
  gpu::BufferPtr raw_depth;     // uint16 units (packed), level-0 size
  gpu::BufferPtr rgb;           // RGB8 bytes, level-0 size
  gpu::BufferPtr depth_raw_m;   // float metres before the bilateral filter
  std::vector<Level> levels;

  static FramePyramid allocate(gpu::Context& ctx, const Intrinsics& intrinsics, int levels, const std::string& name);

  // Depth travels to the GPU as 16-bit units of 0.2 mm (TUM's 1/5000 m): half the bytes of
  // float, and the quantisation is far below any depth sensor's noise. Range: up to 13.1 m.
  static constexpr float kUploadMetresPerUnit = 1.0f / 5000.0f;
  // Uploads level-0 inputs: `depth_m` (width*height floats, metres; 0, NaN, negative = no
  // reading) and `rgb8` (width*height*3 bytes). Synchronous on `stream`.
  void upload(gpu::Stream& stream, const float* depth_m, const uint8_t* rgb8) const;
  // The same, recorded into `cmd` (gpu::record_upload): no submission of its own. The GPU must
  // not be using this frame's input buffers meanwhile.
  void record_upload(gpu::Context& ctx, gpu::CommandList& cmd, const float* depth_m, const uint8_t* rgb8);
  gpu::BufferPtr raw_depth_staging, rgb_staging;  // record_upload's, where the inputs are not mapped
};

class Preprocessor {
 public:
  explicit Preprocessor(gpu::Context& ctx);

  // Single kernels (record into `cmd`; the caller places barriers between dependent steps).
  void depth_to_metres(gpu::CommandList& cmd, const gpu::BufferPtr& raw, const gpu::BufferPtr& depth_m, int width,
                       int height, float metres_per_unit, float min_depth_m, float max_depth_m) const;
  void bilateral_depth(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst, int width, int height,
                       int radius_px, float sigma_space_px, float sigma_depth_m) const;
  void downsample_depth(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst, int src_width,
                        int src_height, float max_depth_diff_m) const;
  void downsample_intensity(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst, int src_width,
                            int src_height) const;
  void rgb_to_intensity(gpu::CommandList& cmd, const gpu::BufferPtr& rgb, const gpu::BufferPtr& intensity, int width,
                        int height) const;
  void vertex_normal_map(gpu::CommandList& cmd, const gpu::BufferPtr& depth_m, const gpu::BufferPtr& vertex,
                         const gpu::BufferPtr& normal, const Intrinsics& intrinsics) const;
  // Gradients of the pixels in `rect` (default: all); reads around it, clamped at the borders.
  void intensity_gradient(gpu::CommandList& cmd, const gpu::BufferPtr& intensity, const gpu::BufferPtr& gradient,
                          int width, int height, const std::optional<PixelRect>& rect = std::nullopt) const;

  // The whole chain for a frame whose raw_depth and rgb buffers are filled.
  void record_frame(gpu::CommandList& cmd, FramePyramid& frame, float metres_per_unit, const PreprocessParams& params) const;

 private:
  gpu::ComputePipeline depth_to_metres_;
  gpu::ComputePipeline bilateral_;
  gpu::ComputePipeline depth_pyramid_;
  gpu::ComputePipeline intensity_pyramid_;
  gpu::ComputePipeline rgb_to_intensity_;
  gpu::ComputePipeline vertex_normal_;
  gpu::ComputePipeline gradient_;
};

}  // namespace cofusion::kernels
