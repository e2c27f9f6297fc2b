// Depth noise of structured-light sensors (Kinect, Xtion), shared by C++ and GLSL. Depends on
// nothing else. Nguyen, Izadi & Lovell 2012: the axial standard deviation on the optical axis is
// sigma(z) = 1.2 mm + 1.9 mm * (z/m - 0.4)^2, so it grows with the square of depth (about 2 mm at
// 1 m, 14 mm at 3 m, 33 mm at 4.5 m).
#ifndef COFUSION_DEPTH_NOISE_H
#define COFUSION_DEPTH_NOISE_H

#ifdef __cplusplus
namespace cofusion::gpu_layout {
#define COFUSION_INLINE inline
#else
#define COFUSION_INLINE
#endif

COFUSION_INLINE float depth_noise_sigma_m(float depth_m) {
  return 0.0012f + 0.0019f * (depth_m - 0.4f) * (depth_m - 0.4f);
}

// sigma(reference_depth_m) / sigma(depth_m) beyond the reference depth, 1 nearer than it or when
// reference_depth_m <= 0: scales a residual at depth_m into units of the noise at the reference.
COFUSION_INLINE float depth_noise_scale(float depth_m, float reference_depth_m) {
  if (reference_depth_m <= 0.0f || depth_m <= reference_depth_m) return 1.0f;
  return depth_noise_sigma_m(reference_depth_m) / depth_noise_sigma_m(depth_m);
}

#undef COFUSION_INLINE
#ifdef __cplusplus
}  // namespace cofusion::gpu_layout
#endif
#endif
