#pragma once
// CPU references of shaders/mask_vertices.comp and shaders/motion_residual.comp (see
// slam/motion_kernels.h), taking the same parameter structs as the shaders.
#include <cstdint>
#include <glm/vec4.hpp>

#include "common/pixel_rect.h"
#include "kernels/image.h"
#include "shared/host_device.h"

namespace cofusion::slam::reference {

// `src`: one pyramid level's vertex map; `labels`: the level-0 label map. `dst`: the output's
// content before (pixels outside [rect_x0, rect_x1) x [rect_y0, rect_y1) keep it).
kernels::Image<glm::vec4> mask_vertices(const kernels::Image<glm::vec4>& src, const kernels::Image<uint32_t>& labels,
                                        int level, uint32_t keep_mask, kernels::Image<glm::vec4> dst,
                                        const PixelRect& rect);
// Every pixel (dst all zero before).
kernels::Image<glm::vec4> mask_vertices(const kernels::Image<glm::vec4>& src, const kernels::Image<uint32_t>& labels,
                                        int level, uint32_t keep_mask);

// Live and reference maps at level 0, all p.width x p.height. `out`: the output's content before
// (pixels outside p's rectangle keep it; empty = all zero).
kernels::Image<glm::vec4> motion_residuals(const kernels::Image<glm::vec4>& live_vertex,
                                           const kernels::Image<float>& live_intensity,
                                           const kernels::Image<glm::vec4>& ref_vertex,
                                           const kernels::Image<glm::vec4>& ref_normal,
                                           const kernels::Image<float>& ref_intensity,
                                           const gpu_layout::MotionResidualParams& p,
                                           kernels::Image<glm::vec4> out = {});

}  // namespace cofusion::slam::reference
