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
static_assert(sizeof(GradientParams) == 24 && offsetof(GradientParams, x0) == 8);
static_assert(sizeof(TestFillParams) == 8);
static_assert(sizeof(TestTexelParams) == 8);
static_assert(sizeof(TestCompactionParams) == 8);
static_assert(sizeof(CompactionScanParams) == 16 && offsetof(CompactionScanParams, count_slot) == 8);
static_assert(sizeof(IndirectGroupsParams) == 16 && offsetof(IndirectGroupsParams, group_size_b) == 12);
static_assert(sizeof(SplatParams) == 100 && offsetof(SplatParams, fx) == 48 && offsetof(SplatParams, footprint_px) == 92 &&
              offsetof(SplatParams, offset_penalty_rel) == 96);
static_assert(sizeof(ResolveParams) == 112 && offsetof(ResolveParams, width) == 64 && offsetof(ResolveParams, x0) == 80 &&
              offsetof(ResolveParams, area_x0) == 96);
static_assert(sizeof(SubsampleParams) == 32 && offsetof(SubsampleParams, x0) == 16);
static_assert(sizeof(FuseParams) == 128 && offsetof(FuseParams, colour_gain) == 120 &&
              offsetof(FuseParams, new_surfel_clearance_cells) == 124 && offsetof(FuseParams, fx) == 48 &&
              offsetof(FuseParams, label_mask) == 100 &&
              offsetof(FuseParams, rect_x0) == 104);
// Vulkan guarantees 128 bytes of push constants.
static_assert(sizeof(FuseParams) <= 128 && sizeof(SplatParams) <= 128 && sizeof(CleanupParams) <= 128 &&
              sizeof(ResolveParams) <= 128);
static_assert(sizeof(CleanupParams) == 100 && offsetof(CleanupParams, free_space_penalty) == 92 &&
              offsetof(CleanupParams, merge) == 96);
static_assert(sizeof(MergeParams) == 124 && offsetof(MergeParams, max_source_confidence) == 116 &&
              offsetof(MergeParams, window_step) == 120 && offsetof(MergeParams, width) == 64 &&
              offsetof(MergeParams, rect_x0) == 80 && offsetof(MergeParams, window_cells) == 96 &&
              offsetof(MergeParams, label_mask) == 112);
static_assert(sizeof(RemoveRegionParams) == 96 && offsetof(RemoveRegionParams, fx) == 48 &&
              offsetof(RemoveRegionParams, label) == 76 && offsetof(RemoveRegionParams, margin_rel) == 80);
static_assert(sizeof(MaskVerticesParams) == 40 && offsetof(MaskVerticesParams, level) == 16 &&
              offsetof(MaskVerticesParams, keep_mask) == 20 && offsetof(MaskVerticesParams, rect_x0) == 24);
static_assert(sizeof(MotionResidualParams) == 92 && offsetof(MotionResidualParams, live_intensity_gain) == 88 &&
              offsetof(MotionResidualParams, fx) == 48 &&
              offsetof(MotionResidualParams, height) == 68 && offsetof(MotionResidualParams, rect_x0) == 72);
static_assert(sizeof(RemoveRegionParams) <= 128 && sizeof(MaskVerticesParams) <= 128 &&
              sizeof(MotionResidualParams) <= 128);
static_assert(sizeof(Surfel) == 48 && offsetof(Surfel, nx) == 16 && offsetof(Surfel, colour_rgba8) == 32);
static_assert(sizeof(IcpRgbReduceParams) == 128 && offsetof(IcpRgbReduceParams, gradient_weight_c) == 124 && offsetof(IcpRgbReduceParams, icp_noise_reference_depth_m) == 120 && offsetof(IcpRgbReduceParams, rgb_huber_delta) == 104 &&
              offsetof(IcpRgbReduceParams, outline_occlusion_margin_m) == 112 && offsetof(IcpRgbReduceParams, icp_huber_delta_m) == 116 &&
              offsetof(IcpRgbReduceParams, live_intensity_gain) == 108 && offsetof(IcpRgbReduceParams, fx) == 48 &&
              offsetof(IcpRgbReduceParams, width) == 64 && offsetof(IcpRgbReduceParams, flags) == 84 &&
              offsetof(IcpRgbReduceParams, rect_x0y0) == 88 &&
              offsetof(IcpRgbReduceParams, outline_rgb_delta) == 92 && offsetof(IcpRgbReduceParams, rect_width) == 96 && sizeof(IcpRgbReduceParams) <= 128);
static_assert(ICP_RGB_OFFSET_VALID >= ICP_RGB_OFFSET_ICP + ICP_RGB_TERM_VALUES && ICP_RGB_OFFSET_RGB > ICP_RGB_OFFSET_VALID &&
              ICP_RGB_OFFSET_RGB + ICP_RGB_TERM_VALUES <= ICP_RGB_PARTIAL_STRIDE && ICP_RGB_PARTIAL_STRIDE == 64);
// The intensity sums ride in the photometric term's last vec4 (after its count).
static_assert(ICP_RGB_OFFSET_REF_INTENSITY == ICP_RGB_OFFSET_RGB + ICP_RGB_TERM_VALUES &&
              ICP_RGB_OFFSET_LIVE_INTENSITY == ICP_RGB_OFFSET_REF_INTENSITY + 1 &&
              ICP_RGB_OFFSET_LIVE_INTENSITY < ICP_RGB_PARTIAL_STRIDE);
static_assert(ICP_RGB_GROUP_SIZE / ICP_RGB_MAX_SUBGROUPS == 4);
// renderer/ (view_splat.comp, view_resolve.comp)
static_assert(sizeof(ViewSplatParams) == 96 && offsetof(ViewSplatParams, fx) == 48 &&
              offsetof(ViewSplatParams, index_base) == 76 && offsetof(ViewSplatParams, near_m) == 88);
static_assert(sizeof(ViewResolveParams) == 80 && offsetof(ViewResolveParams, width) == 48 &&
              offsetof(ViewResolveParams, ambient) == 76);
}  // namespace cofusion::gpu_layout
