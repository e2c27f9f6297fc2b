#include "slam/tracker_reference.h"

#include <cmath>
#include <numbers>

#include "common/error.h"
#include "shared/depth_noise.h"
#include "shared/host_device.h"

namespace cofusion::slam::reference {
namespace {
using Term = std::array<double, LinearSystemSums::kTermValues>;

void add(Term& s, const Vector6d& J, double r) {
  int k = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) s[k++] += J(i) * J(j);
  for (int i = 0; i < 6; ++i) s[21 + i] += J(i) * r;
  s[27] += r * r;
  s[28] += 1;
}

Eigen::Vector3d xyz(const glm::vec4& v) { return {v.x, v.y, v.z}; }

// Bilinear interpolation at (x, y) over the 2x2 pixels from (floor x, floor y); the caller keeps
// them inside the image.
struct Bilinear {
  int x0, y0;
  double w00, w10, w01, w11;
  Bilinear(double x, double y) : x0(static_cast<int>(std::floor(x))), y0(static_cast<int>(std::floor(y))) {
    const double ax = x - x0, ay = y - y0;
    w00 = (1 - ax) * (1 - ay), w10 = ax * (1 - ay), w01 = (1 - ax) * ay, w11 = ax * ay;
  }
  template <typename Image, typename Get>
  double operator()(const Image& image, Get get) const {
    return w00 * get(image.at(x0, y0)) + w10 * get(image.at(x0 + 1, y0)) + w01 * get(image.at(x0, y0 + 1)) +
           w11 * get(image.at(x0 + 1, y0 + 1));
  }
};
double intensity_of(float i) { return double(i); }
double gradient_x(const glm::vec2& g) { return double(g.x); }
double gradient_y(const glm::vec2& g) { return double(g.y); }

// Chain rule: dI/dq = (gx, gy) * d pi(q) / dq, pi(q) = (fx qx/qz + cx, fy qy/qz + cy).
Eigen::Vector3d intensity_jacobian(double gx, double gy, const Intrinsics& k, const Eigen::Vector3d& q) {
  const double z = q.z();
  return {gx * k.fx / z, gy * k.fy / z, -(gx * k.fx * q.x() + gy * k.fy * q.y()) / (z * z)};
}

// Huber weight, applied as sqrt(w) to J and r: sums of w J^T J, w J^T r, w r^2.
double huber_sqrt_weight(double r, double delta) {
  return delta > 0 && std::abs(r) > delta ? std::sqrt(delta / std::abs(r)) : 1.0;
}

// Cauchy's weight 1 / (1 + (r / delta)^2), applied as its sqrt (TrackerParams::photometric_cauchy_k).
double cauchy_sqrt_weight(double r, double delta) {
  return delta > 0 ? 1.0 / std::sqrt(1.0 + (r / delta) * (r / delta)) : 1.0;
}

// A photometric residual's robust sqrt weight: Cauchy's or Huber's (TrackerParams).
double photometric_robust_sqrt_weight(double r, double delta, const TrackerParams& params) {
  return params.photometric_cauchy_k > 0 ? cauchy_sqrt_weight(r, delta) : huber_sqrt_weight(r, delta);
}

// sqrt of the weight of the tile holding live pixel (x, y) of a w x h level (ICP_RGB_FLAG_TILE_WEIGHTS).
double tile_sqrt_weight(std::span<const float> tile_weights, int x, int y, int w, int h) {
  return tile_weights.empty() ? 1.0 : std::sqrt(double(tile_weights[size_t(gpu_layout::icp_rgb_tile(x, y, w, h))]));
}

// sqrt of the gradient weight c^2 / (c^2 + |g|^2) (TrackerParams::photometric_gradient_c).
double gradient_sqrt_weight(double gx, double gy, double c) {
  return c > 0 ? std::sqrt(c * c / (c * c + gx * gx + gy * gy)) : 1.0;
}

template <typename T>
kernels::Image<T> download_image(gpu::Stream& stream, const gpu::BufferPtr& buffer, int w, int h) {
  kernels::Image<T> image(w, h);
  stream.download(buffer, image.pixels.data(), image.bytes());
  return image;
}

void check_same_size(const HostLevel& a, const HostLevel& b, const std::string& what) {
  const int w = a.intrinsics.width, h = a.intrinsics.height;
  auto ok = [&](const auto& image) { return image.width == w && image.height == h; };
  if (!ok(a.vertex) || !ok(a.normal) || !ok(a.intensity) || !ok(b.vertex) || !ok(b.normal) || !ok(b.intensity) ||
      !ok(a.gradient) || !ok(b.gradient) || b.intrinsics.width != w || b.intrinsics.height != h)
    throw Error(what + ": maps of live and reference levels differ in size from the intrinsics " +
                a.intrinsics.to_string());
}
}  // namespace

HostLevel download_level(gpu::Stream& stream, const kernels::FramePyramid::Level& level) {
  HostLevel out;
  out.intrinsics = level.intrinsics;
  const int w = level.width, h = level.height;
  out.vertex = download_image<glm::vec4>(stream, level.vertex, w, h);
  out.normal = download_image<glm::vec4>(stream, level.normal, w, h);
  out.intensity = download_image<float>(stream, level.intensity, w, h);
  out.gradient = download_image<glm::vec2>(stream, level.gradient, w, h);
  if (level.depth_m) out.depth_m = download_image<float>(stream, level.depth_m, w, h);  // predictions have none
  return out;
}

std::vector<HostLevel> download_levels(gpu::Stream& stream, const std::vector<kernels::FramePyramid::Level>& levels) {
  std::vector<HostLevel> out;
  for (const auto& level : levels) out.push_back(download_level(stream, level));
  return out;
}

namespace {
// Whether reference pixel (u, v) is on the prediction's rim: at the image's edge or with a
// 4-neighbour the prediction does not cover.
bool on_rim(const HostLevel& ref, int u, int v) {
  const int w = ref.intrinsics.width, h = ref.intrinsics.height;
  return u == 0 || v == 0 || u == w - 1 || v == h - 1 || !(ref.vertex.at(u - 1, v).w > 0) ||
         !(ref.vertex.at(u + 1, v).w > 0) || !(ref.vertex.at(u, v - 1).w > 0) || !(ref.vertex.at(u, v + 1).w > 0);
}

// The outline, model -> live (see TrackerParams::outline_photometric and icp_rgb_reduce.comp):
// each reference pixel of `area` against the live intensity where the motion puts it.
void add_outline_term(const HostLevel& live, const HostLevel& ref, const Eigen::Isometry3d& T,
                      const TrackerParams& params, const PixelRect& area, const IterationScales& scales,
                      std::span<const float> tile_weights, LinearSystemSums& sums) {
  const Intrinsics& k = live.intrinsics;
  const int w = k.width, h = k.height;
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Matrix3d Rt = R.transpose();
  const Eigen::Vector3d t_inv = -(Rt * T.translation());
  for (int v = area.y0; v < area.y1; ++v)
    for (int u = area.x0; u < area.x1; ++u) {
      const glm::vec4& v_ref4 = ref.vertex.at(u, v);
      if (!(v_ref4.w > 0)) continue;
      if (on_rim(ref, u, v)) continue;  // splats overhang the silhouette there
      const Eigen::Vector3d v_ref = xyz(v_ref4);
      const Eigen::Vector3d x_live = Rt * v_ref + t_inv;
      if (!(x_live.z() > 0)) continue;
      const double x = k.fx * x_live.x() / x_live.z() + k.cx, y = k.fy * x_live.y() / x_live.z() + k.cy;
      if (!(x >= 0 && y >= 0 && x < w - 1 && y < h - 1)) continue;
      const float z_live = live.depth_m.width == w && live.depth_m.height == h
                               ? live.depth_m.at(static_cast<int>(std::floor(x + 0.5)), static_cast<int>(std::floor(y + 0.5)))
                               : 0.0f;
      if (z_live > 0 && z_live < x_live.z() - params.outline_occlusion_margin_m) continue;  // occluded
      const Bilinear b(x, y);
      const double gain = scales.live_gain;
      const double r = (gain * b(live.intensity, intensity_of) - ref.intensity.at(u, v)) / 255.0;
      if (!(std::abs(r) <= params.max_intensity_diff)) continue;
      const double gx = gain * b(live.gradient, gradient_x) / 255.0, gy = gain * b(live.gradient, gradient_y) / 255.0;
      const Eigen::Vector3d G = R * intensity_jacobian(gx, gy, k, x_live);
      const double sw = photometric_robust_sqrt_weight(r, scales.rgb * params.outline_huber_scale, params) *
                        gradient_sqrt_weight(gx, gy, params.photometric_gradient_c) *
                        tile_sqrt_weight(tile_weights, static_cast<int>(std::floor(x + 0.5)),
                                         static_cast<int>(std::floor(y + 0.5)), w, h);
      Vector6d J;
      J << -sw * G, -sw * v_ref.cross(G);
      add(sums.rgb, J, sw * r);
    }
}
}  // namespace

LinearSystemSums compute_sums(const HostLevel& live, const HostLevel& ref, const Eigen::Isometry3d& T,
                              const TrackerParams& params, const std::optional<PixelRect>& rect,
                              const IterationScales& scales, std::span<const float> tile_weights) {
  check_same_size(live, ref, "tracker reference");
  if (!params.photometric_tile_weights) tile_weights = {};
  if (!tile_weights.empty() && tile_weights.size() != size_t(ICP_RGB_TILES_X * ICP_RGB_TILES_Y))
    throw Error("tracker reference: " + std::to_string(tile_weights.size()) + " tile weights");
  const Intrinsics& k = live.intrinsics;
  const int w = k.width, h = k.height;
  const Eigen::Matrix3d R = T.linear();
  const double max_d = params.max_correspondence_distance_m;
  const double min_cos = std::cos(params.max_normal_angle_deg * std::numbers::pi / 180.0);
  const PixelRect area = rect ? rect->clamped(w, h) : PixelRect::full(w, h);
  LinearSystemSums sums;
  for (int v = area.y0; v < area.y1; ++v)
    for (int u = area.x0; u < area.x1; ++u) {
      const glm::vec4& v_live = live.vertex.at(u, v);
      if (!(v_live.w > 0)) continue;
      const glm::vec4& n_live = live.normal.at(u, v);
      const bool normal_valid = n_live.w > 0;
      if (normal_valid) sums.valid_live_pixels += 1;
      const Eigen::Vector3d q = T * xyz(v_live);
      if (!(q.z() > 0)) continue;
      const double x = k.fx * q.x() / q.z() + k.cx, y = k.fy * q.y() / q.z() + k.cy;
      if (!(x >= -0.5 && y >= -0.5 && x < w - 0.5 && y < h - 0.5)) continue;
      const int xn = static_cast<int>(std::floor(x + 0.5)), yn = static_cast<int>(std::floor(y + 0.5));
      const glm::vec4& v_ref = ref.vertex.at(xn, yn);
      if (!(v_ref.w > 0)) continue;
      if (normal_valid && v_ref.z - q.z() > max_d) sums.occluding_live_pixels += 1;

      if (normal_valid) {
        const glm::vec4& n_ref4 = ref.normal.at(xn, yn);
        const Eigen::Vector3d n_ref = xyz(n_ref4), d = q - xyz(v_ref);
        if (n_ref4.w > 0 && d.norm() <= max_d && (R * xyz(n_live)).dot(n_ref) >= min_cos) {
          Vector6d J;
          J << n_ref, q.cross(n_ref);
          const double r = n_ref.dot(d);
          const double sw = huber_sqrt_weight(r, scales.icp_m) *
                            gpu_layout::depth_noise_scale(v_live.z, float(params.icp_noise_reference_depth_m));
          add(sums.icp, sw * J, sw * r);
        }
      }

      if (params.use_photometric && x >= 0 && y >= 0 && x < w - 1 && y < h - 1 &&
          std::abs(q.z() - v_ref.z) <= max_d) {
        const Bilinear b(x, y);
        if (params.photometric_skip_rim && on_rim(ref, xn, yn)) continue;
        if (!(ref.vertex.at(b.x0, b.y0).w > 0 && ref.vertex.at(b.x0 + 1, b.y0).w > 0 && ref.vertex.at(b.x0, b.y0 + 1).w > 0 &&
              ref.vertex.at(b.x0 + 1, b.y0 + 1).w > 0))
          continue;
        const double I_ref = b(ref.intensity, intensity_of), I_live = live.intensity.at(u, v);
        sums.reference_intensity_sum += I_ref;
        sums.live_intensity_sum += I_live;
        const double r = (I_ref - scales.live_gain * I_live) / 255.0;
        if (!(std::abs(r) <= params.max_intensity_diff)) continue;
        double gx = b(ref.gradient, gradient_x) / 255.0, gy = b(ref.gradient, gradient_y) / 255.0;
        if (params.esm_gradient) {  // mean with the live gradient at the pixel
          gx = 0.5 * (gx + scales.live_gain * live.gradient.at(u, v).x / 255.0);
          gy = 0.5 * (gy + scales.live_gain * live.gradient.at(u, v).y / 255.0);
        }
        const Eigen::Vector3d dI_dq = intensity_jacobian(gx, gy, k, q);
        const double sw = photometric_robust_sqrt_weight(r, scales.rgb, params) *
                          gradient_sqrt_weight(gx, gy, params.photometric_gradient_c) *
                          tile_sqrt_weight(tile_weights, u, v, w, h);
        Vector6d J;
        J << sw * dI_dq, sw * q.cross(dI_dq);
        add(sums.rgb, J, sw * r);
      }
    }
  if (params.use_photometric && params.outline_photometric) add_outline_term(live, ref, T, params, area, scales, tile_weights, sums);
  return sums;
}

TrackingResult track(const std::vector<HostLevel>& live, const std::vector<HostLevel>& reference,
                     const Eigen::Isometry3d& guess, const TrackerParams& params) {
  validate(params, "reference::track");
  if (live.empty() || live.size() != reference.size())
    throw Error("reference::track: live has " + std::to_string(live.size()) + " levels, reference " +
                std::to_string(reference.size()));
  if (live.size() > params.iterations_per_level.size())
    throw Error("reference::track: more pyramid levels than iterations_per_level entries");
  std::vector<long> pixels;
  for (const auto& level : live) pixels.push_back(static_cast<long>(level.intrinsics.width) * level.intrinsics.height);
  return gauss_newton(
      pixels,
      [&](int level, const Eigen::Isometry3d& T, const IterationScales& scales) {
        return compute_sums(live[level], reference[level], T, params, std::nullopt, scales);
      },
      guess, params);
}

}  // namespace cofusion::slam::reference
