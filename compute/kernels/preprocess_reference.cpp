#include "kernels/preprocess_reference.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace cofusion::kernels::reference {

Image<float> depth_to_metres(const Image<uint16_t>& raw, float metres_per_unit, float min_depth_m, float max_depth_m) {
  Image<float> out(raw.width, raw.height);
  for (size_t i = 0; i < raw.size(); ++i) {
    const float d = static_cast<float>(raw.pixels[i]) * metres_per_unit;
    out.pixels[i] = (raw.pixels[i] == 0 || d < min_depth_m || d > max_depth_m) ? 0.0f : d;
  }
  return out;
}

Image<float> bilateral_depth(const Image<float>& in, int radius_px, float sigma_space_px, float sigma_depth_m) {
  Image<float> out(in.width, in.height);
  const double inv_2ss = 0.5 / (double(sigma_space_px) * sigma_space_px);
  const double inv_2sd = 0.5 / (double(sigma_depth_m) * sigma_depth_m);
  for (int y = 0; y < in.height; ++y)
    for (int x = 0; x < in.width; ++x) {
      const float centre = in.at(x, y);
      if (centre <= 0.0f) continue;
      double sum = 0, weight_sum = 0;
      for (int v = std::max(0, y - radius_px); v <= std::min(in.height - 1, y + radius_px); ++v)
        for (int u = std::max(0, x - radius_px); u <= std::min(in.width - 1, x + radius_px); ++u) {
          const float d = in.at(u, v);
          if (d <= 0.0f) continue;
          const double dist2 = double(u - x) * (u - x) + double(v - y) * (v - y);
          const double w = std::exp(-dist2 * inv_2ss - double(d - centre) * (d - centre) * inv_2sd);
          sum += w * d;
          weight_sum += w;
        }
      out.at(x, y) = static_cast<float>(sum / weight_sum);
    }
  return out;
}

Image<float> downsample_depth(const Image<float>& in, float max_depth_diff_m) {
  Image<float> out(half_size(in.width), half_size(in.height));
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      float ref = 0, sum = 0;
      int count = 0;
      for (int v = 2 * y; v <= std::min(2 * y + 1, in.height - 1); ++v)
        for (int u = 2 * x; u <= std::min(2 * x + 1, in.width - 1); ++u) {
          const float d = in.at(u, v);
          if (d <= 0.0f) continue;
          if (ref == 0.0f) ref = d;
          if (std::abs(d - ref) <= max_depth_diff_m) {
            sum += d;
            ++count;
          }
        }
      out.at(x, y) = count ? sum / static_cast<float>(count) : 0.0f;
    }
  return out;
}

Image<float> downsample_intensity(const Image<float>& in) {
  Image<float> out(half_size(in.width), half_size(in.height));
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      float sum = 0;
      int count = 0;
      for (int v = 2 * y; v <= std::min(2 * y + 1, in.height - 1); ++v)
        for (int u = 2 * x; u <= std::min(2 * x + 1, in.width - 1); ++u) {
          sum += in.at(u, v);
          ++count;
        }
      out.at(x, y) = sum / static_cast<float>(count);
    }
  return out;
}

Image<float> rgb_to_intensity(const uint8_t* rgb, int width, int height) {
  Image<float> out(width, height);
  for (size_t i = 0; i < out.size(); ++i)
    out.pixels[i] = static_cast<float>(rgb[3 * i] + rgb[3 * i + 1] + rgb[3 * i + 2]) / 3.0f;
  return out;
}

void vertex_normal_map(const Image<float>& depth, const Intrinsics& k, Image<glm::vec4>& vertex, Image<glm::vec4>& normal) {
  vertex = Image<glm::vec4>(depth.width, depth.height, glm::vec4(0));
  normal = Image<glm::vec4>(depth.width, depth.height, glm::vec4(0));
  const auto back_project = [&](int x, int y, float d) {
    return glm::vec3((float(x) - float(k.cx)) * d / float(k.fx), (float(y) - float(k.cy)) * d / float(k.fy), d);
  };
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x) {
      const float d = depth.at(x, y);
      if (d <= 0.0f) continue;
      const glm::vec3 v = back_project(x, y, d);
      vertex.at(x, y) = glm::vec4(v, 1.0f);
      if (x < 1 || y < 1 || x + 1 >= depth.width || y + 1 >= depth.height) continue;
      const float dl = depth.at(x - 1, y), dr = depth.at(x + 1, y), du = depth.at(x, y - 1), dd = depth.at(x, y + 1);
      if (dl <= 0.0f || dr <= 0.0f || du <= 0.0f || dd <= 0.0f) continue;
      glm::vec3 c = glm::cross(back_project(x + 1, y, dr) - back_project(x - 1, y, dl),
                               back_project(x, y + 1, dd) - back_project(x, y - 1, du));
      const float len = glm::length(c);
      if (len <= 0.0f) continue;
      c /= len;
      normal.at(x, y) = glm::vec4(glm::dot(c, v) > 0.0f ? -c : c, 1.0f);
    }
}

Image<glm::vec2> intensity_gradient(const Image<float>& in) {
  Image<glm::vec2> out(in.width, in.height);
  const auto at = [&](int x, int y) {
    return in.at(std::clamp(x, 0, in.width - 1), std::clamp(y, 0, in.height - 1));
  };
  for (int y = 0; y < in.height; ++y)
    for (int x = 0; x < in.width; ++x) {
      const float gx = (at(x + 1, y - 1) + 2 * at(x + 1, y) + at(x + 1, y + 1)) -
                       (at(x - 1, y - 1) + 2 * at(x - 1, y) + at(x - 1, y + 1));
      const float gy = (at(x - 1, y + 1) + 2 * at(x, y + 1) + at(x + 1, y + 1)) -
                       (at(x - 1, y - 1) + 2 * at(x, y - 1) + at(x + 1, y - 1));
      out.at(x, y) = glm::vec2(gx, gy) * 0.125f;
    }
  return out;
}

}  // namespace cofusion::kernels::reference
