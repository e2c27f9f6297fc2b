#version 460
// Workgroup counts for two indirect dispatches over n = min(counter[count_slot], bound) elements
// (shared/host_device.h, IndirectGroupsParams): what only the GPU knows, without a round trip.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/small_division.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = INDIRECT_GROUPS_BINDING_COUNTER) readonly buffer Counter { uint counter[]; };
layout(std430, binding = INDIRECT_GROUPS_BINDING_ARGS) writeonly buffer Args { uint args[]; };
layout(push_constant) uniform Push { IndirectGroupsParams p; };

void main() {
  const uint n = min(counter[p.count_slot], p.bound);
  args[0] = ceil_quotient(n, p.group_size_a);
  args[1] = 1u;
  args[2] = 1u;
  args[INDIRECT_GROUPS_B_WORD] = ceil_quotient(n, p.group_size_b);
  args[INDIRECT_GROUPS_B_WORD + 1] = 1u;
  args[INDIRECT_GROUPS_B_WORD + 2] = 1u;
}
