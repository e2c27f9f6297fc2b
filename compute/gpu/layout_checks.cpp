// Compile-time checks that the C++ view of shaders/shared/host_device.h matches std430 /
// push-constant layout as GLSL sees it.
#include <cstddef>

#include "shared/host_device.h"

namespace cofusion::gpu_layout {
static_assert(sizeof(DepthToMetresParams) == 20 && offsetof(DepthToMetresParams, max_depth_m) == 16);
static_assert(sizeof(BilateralParams) == 20 && offsetof(BilateralParams, sigma_depth_m) == 16);
static_assert(sizeof(DownsampleParams) == 20 && offsetof(DownsampleParams, max_depth_diff_m) == 16);
static_assert(sizeof(IntensityParams) == 8);
static_assert(sizeof(VertexNormalParams) == 24 && offsetof(VertexNormalParams, cy) == 20);
static_assert(sizeof(GradientParams) == 8);
static_assert(sizeof(TestFillParams) == 8);
}  // namespace cofusion::gpu_layout
