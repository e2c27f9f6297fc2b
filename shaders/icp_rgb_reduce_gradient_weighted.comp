#version 460
// icp_rgb_reduce.comp with gradient-dependent photometric weights: each photometric residual and
// its Jacobian scaled by sqrt(c^2 / (c^2 + |g|^2)) (TrackerParams::photometric_gradient_c). A
// separate kernel, so that the default one is compiled exactly as without the option.
#extension GL_GOOGLE_include_directive : require
#define ICP_RGB_GRADIENT_WEIGHTS
#include "shared/icp_rgb_reduce.glsl"
