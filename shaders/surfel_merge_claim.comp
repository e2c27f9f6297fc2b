#version 460
// Per surfel with a merge target that stays (has no target itself): claims the target for the
// lowest source index (atomicMin), so each kept surfel absorbs one source per frame.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
layout(local_size_x = 128) in;
layout(std430, binding = MERGE_BINDING_SURFELS) readonly buffer Surfels { uint surfels_unused[]; };
layout(std430, binding = MERGE_BINDING_INDEX_MAP) readonly buffer IndexMap { uint index_map_unused[]; };
layout(binding = MERGE_BINDING_TARGET) uniform usamplerBuffer target;  // texel view of uint
layout(std430, binding = MERGE_BINDING_CLAIM) buffer Claim { uint claim[]; };
layout(std430, binding = MERGE_BINDING_COUNTER) readonly buffer Counter { uint counter[]; };
layout(std430, binding = MERGE_BINDING_LABELS) readonly buffer Labels { uint labels_unused[]; };
layout(push_constant) uniform Push { MergeParams p; };
void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= min(p.surfel_count, counter[0])) return;
  const uint t = texel_uint(target, i);
  if (t != MERGE_NONE && texel_uint(target, t) == MERGE_NONE) atomicMin(claim[t], i);
}
