#version 460
// One Gauss-Newton iteration of frame-to-model tracking (Co-Fusion eq. 1-3): the point-to-plane
// ICP system and the photometric system, reduced in one dispatch. The layout of the partial sums
// is described in shared/host_device.h; compute/slam/tracker_reference.cpp is the CPU reference.
//
// Reduction: each invocation accumulates its pixels (grid-stride loop) in registers, then one
// subgroupAdd per value and one shared-memory step across the subgroups of the workgroup, behind
// a single barrier. On lavapipe this is about 10x faster than a shared-memory tree (one barrier
// per halving). The host adds the workgroups' partials in double. The maps are read through
// their texel views (shared/texel_access.glsl).
#extension GL_GOOGLE_include_directive : require
#include "shared/icp_rgb_reduce.glsl"
