// Struct layouts and binding numbers shared by C++ and GLSL. Depends on nothing else.
// Rules: scalars and vec4-sized members only (no vec3 in std430 arrays); every struct used on
// the C++ side has static_asserts on size and offsets in compute/gpu/layout_checks.cpp.
#ifndef COFUSION_HOST_DEVICE_H
#define COFUSION_HOST_DEVICE_H

#ifdef __cplusplus
#include <cstdint>
namespace cofusion::gpu_layout {
using uint = std::uint32_t;
#endif

// Every 2D kernel runs 16x16 workgroups (one invocation per output pixel).
#define COFUSION_TILE 16

// ---- depth_to_metres.comp: uint16 depth (packed 2 per uint) -> float metres -------------
#define DEPTH_TO_METRES_BINDING_RAW 0    // uint[]  raw 16-bit units, little-endian pairs
#define DEPTH_TO_METRES_BINDING_DEPTH 1  // float[] metres, 0 = no reading
struct DepthToMetresParams {
  uint width;
  uint height;
  float metres_per_unit;  // 1/5000 for TUM, 1/1000 for OpenNI
  float min_depth_m;      // readings nearer than this become 0
  float max_depth_m;      // readings farther than this become 0 (the depth cut-off)
};

// ---- bilateral_depth.comp: edge-preserving smoothing of metric depth -----------------------
#define BILATERAL_BINDING_SRC 0  // float[] metres
#define BILATERAL_BINDING_DST 1  // float[] metres
struct BilateralParams {
  uint width;
  uint height;
  int radius_px;          // window is (2r+1)^2
  float sigma_space_px;   // spatial Gaussian sigma
  float sigma_depth_m;    // range Gaussian sigma
};

// ---- depth_pyramid.comp / intensity_pyramid.comp: halve resolution -------------------------
#define DOWNSAMPLE_BINDING_SRC 0  // float[]
#define DOWNSAMPLE_BINDING_DST 1  // float[]
struct DownsampleParams {
  uint src_width;
  uint src_height;
  uint dst_width;          // max(1, src_width / 2)
  uint dst_height;         // max(1, src_height / 2)
  float max_depth_diff_m;  // depth only: ignore samples farther than this from the block's first valid one
};

// ---- rgb_to_intensity.comp: RGB8 -> I = (r+g+b)/3 in [0,255] --------------------------------
#define INTENSITY_BINDING_RGB 0        // uint[] packed RGB8 bytes, 3 per pixel
#define INTENSITY_BINDING_INTENSITY 1  // float[]
struct IntensityParams {
  uint width;
  uint height;
};

// ---- vertex_normal_map.comp: metric depth -> camera-frame vertices and normals --------------
#define VERTEX_NORMAL_BINDING_DEPTH 0   // float[] metres
#define VERTEX_NORMAL_BINDING_VERTEX 1  // vec4[] xyz metres, w = 1 valid / 0 invalid
#define VERTEX_NORMAL_BINDING_NORMAL 2  // vec4[] unit normal facing the camera, w = 1 valid / 0 invalid
struct VertexNormalParams {
  uint width;
  uint height;
  float fx;  // pixels, at this pyramid level
  float fy;
  float cx;
  float cy;
};

// ---- intensity_gradient.comp: Sobel gradients of intensity ----------------------------------
#define GRADIENT_BINDING_INTENSITY 0  // float[]
#define GRADIENT_BINDING_GRADIENT 1   // vec2[] (dI/dx, dI/dy) per pixel
struct GradientParams {
  uint width;
  uint height;
};

// ---- test_fill.comp: used by the compute-core tests only -------------------------------------
#define TEST_FILL_BINDING_DST 0
struct TestFillParams {
  uint count;
  uint value_offset;  // dst[i] = i + value_offset
};

#ifdef __cplusplus
}  // namespace cofusion::gpu_layout
#endif
#endif  // COFUSION_HOST_DEVICE_H
