#pragma once
// CPU references of the preprocessing kernels (shaders/*.comp). Straightforward loops written
// independently of the shaders, so the GPU-vs-CPU tests check the shaders' arithmetic and
// indexing, not just the plumbing.
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec4.hpp>

#include "common/intrinsics.h"
#include "kernels/image.h"

namespace cofusion::kernels::reference {

Image<float> depth_to_metres(const Image<uint16_t>& raw, float metres_per_unit, float min_depth_m, float max_depth_m);
Image<float> bilateral_depth(const Image<float>& depth_m, int radius_px, float sigma_space_px, float sigma_depth_m);
Image<float> downsample_depth(const Image<float>& depth_m, float max_depth_diff_m);
Image<float> downsample_intensity(const Image<float>& intensity);
// `rgb` holds width*height*3 bytes, R,G,B per pixel.
Image<float> rgb_to_intensity(const uint8_t* rgb, int width, int height);
// Camera-frame vertices (w = 1 valid) and camera-facing unit normals (w = 1 valid).
void vertex_normal_map(const Image<float>& depth_m, const Intrinsics& intrinsics, Image<glm::vec4>& vertex,
                       Image<glm::vec4>& normal);
Image<glm::vec2> intensity_gradient(const Image<float>& intensity);

}  // namespace cofusion::kernels::reference
