#pragma once
// Kinect-like depth (and colour) noise for synthetic frames, and the counter-based random numbers
// that make it deterministic per (seed, frame, pixel) so frames render independently and in
// parallel.
//
// Model, applied to the noise-free rendering per pixel (u, v), in this order:
//  1. Lateral noise: the depth reading is taken from the pixel nearest to (u + du, v + dv) with
//     du, dv ~ N(0, lateral_sigma_px) (the IR pattern's correlation window smears edges).
//  2. Holes: no reading (0) where the incidence angle theta between ray and surface normal exceeds
//     max_incidence_deg, or — with probability edge_drop_probability — where a neighbour within
//     edge_radius_px differs in depth by more than edge_jump_ratio * z (depth discontinuities).
//  3. Axial noise: z += N(0, sigma_z), sigma_z(z, theta) = a0 + a1 (z - z0)^2
//     + a2 / sqrt(z) * theta^2 / (pi/2 - theta)^2   (Nguyen, Izadi, Lovell 2012, 3DIMPVT).
//     The normal numbers come from a 4096-level quantile table (unit variance, tails cut at
//     +-3.5 sigma).
//  4. Disparity quantisation: d = f b / z in pixels, rounded to 1/subpixel px:
//     z_q = f b / (round(subpixel f b / z) / subpixel), f = fx, b = baseline_m. Step at depth z is
//     about z^2 / (subpixel f b): 3.2 mm at 1 m, 12.7 mm at 2 m for the Kinect defaults.
//  5. Range: readings outside [min_depth_m, max_depth_m] become 0.
// Colour: each channel gets zero-mean noise of standard deviation color_sigma (a triangular
// distribution, close enough to Gaussian for sensor noise), then rounds to 8 bits.
#include <cmath>
#include <cstdint>
#include <numbers>

namespace cofusion::synthetic {

struct KinectNoiseParams {
  // Axial noise sigma_z(z, theta) = axial_a0_m + axial_a1_per_m * (z - axial_z0_m)^2
  //                                 + axial_a2 / sqrt(z) * theta^2 / (pi/2 - theta)^2   [metres]
  bool axial = true;
  double axial_a0_m = 0.0012;
  double axial_a1_per_m = 0.0019;  // 1/m
  double axial_z0_m = 0.4;
  double axial_a2 = 0.0001;  // m^1.5
  double lateral_sigma_px = 0.8;  // pixels; 0 = off
  int disparity_subpixel = 8;     // quantisation steps per pixel of disparity; 0 = off
  double baseline_m = 0.075;      // projector-camera baseline, metres
  double max_incidence_deg = 78;  // no reading beyond this angle between ray and normal; >= 90 = off
  double edge_jump_ratio = 0.03;  // relative depth jump that counts as a discontinuity
  double edge_radius_px = 1;      // neighbourhood (Chebyshev radius, pixels) searched for a jump
  double edge_drop_probability = 0.5;  // 0 = off
  double min_depth_m = 0.4;            // readings nearer than this are 0; 0 = off
  double max_depth_m = 8.0;            // readings farther than this are 0; 0 = off
  double color_sigma = 2.0;            // colour noise, 8-bit levels; 0 = off

  // Every effect off: depth_m equals the true depth and colour is the clean shading.
  static KinectNoiseParams none() {
    KinectNoiseParams p;
    p.axial = false;
    p.lateral_sigma_px = 0;
    p.disparity_subpixel = 0;
    p.max_incidence_deg = 90;
    p.edge_drop_probability = 0;
    p.min_depth_m = 0;
    p.max_depth_m = 0;
    p.color_sigma = 0;
    return p;
  }

  // Standard deviation of the axial noise (metres) at depth z_m and incidence angle theta_rad.
  // T = float in the renderer, double in checks: one formula for both.
  template <typename T>
  T axial_sigma_m(T z_m, T theta_rad) const {
    if (!axial) return T(0);
    const T g = theta_rad / (std::numbers::pi_v<T> / 2 - theta_rad);
    const T dz = z_m - static_cast<T>(axial_z0_m);
    return static_cast<T>(axial_a0_m) + static_cast<T>(axial_a1_per_m) * dz * dz +
           static_cast<T>(axial_a2) / std::sqrt(z_m) * g * g;
  }

  // Depth after disparity quantisation with focal length fx_px; z_m unchanged when off.
  template <typename T>
  T quantize(T z_m, T fx_px) const {
    if (disparity_subpixel <= 0 || z_m <= 0) return z_m;
    const T fb = fx_px * static_cast<T>(baseline_m);
    const T sub = static_cast<T>(disparity_subpixel);
    const T steps = std::floor(sub * fb / z_m + T(0.5));  // round half up (positive values)
    return steps > 0 ? fb * sub / steps : T(0);
  }

  // Quantisation step (metres) at depth z_m, 0 when off.
  double quantization_step_m(double z_m, double fx_px) const {
    return disparity_subpixel > 0 ? z_m * z_m / (disparity_subpixel * fx_px * baseline_m) : 0.0;
  }
};

// Counter-based random numbers: a strong 64-bit mix of (seed, frame, pixel, stream), so any pixel of
// any frame can be drawn independently of all others (SplitMix64 finaliser).
inline uint64_t mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

inline uint64_t hash_counter(uint64_t seed, uint64_t frame, uint64_t index, uint64_t stream) {
  return mix64(mix64(mix64(seed) ^ (frame * 0xD1B54A32D192ED03ull + stream)) + index);
}

// Uniform in [0, 1) from the top 24 bits of a 32-bit value.
inline float unit_float(uint32_t bits) { return static_cast<float>(bits >> 8) * (1.0f / 16777216.0f); }

}  // namespace cofusion::synthetic
