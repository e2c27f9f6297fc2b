#version 460
// icp_rgb_reduce.comp with reweighted photometric residuals: gradient-dependent weights
// sqrt(c^2 / (c^2 + |g|^2)) where IcpRgbReduceParams::gradient_weight_c > 0
// (TrackerParams::photometric_gradient_c), and Cauchy's robust weight instead of Huber's with
// ICP_RGB_FLAG_CAUCHY (TrackerParams::photometric_cauchy_k). A separate kernel, so that the
// default one is compiled exactly as without these options.
#extension GL_GOOGLE_include_directive : require
#define ICP_RGB_REWEIGHTED
#include "shared/icp_rgb_reduce.glsl"
