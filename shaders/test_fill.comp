#version 460
// Compute-core test kernel: dst[i] = i + value_offset.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
layout(local_size_x = 64) in;
layout(std430, binding = TEST_FILL_BINDING_DST) writeonly buffer Dst { uint dst[]; };
layout(push_constant) uniform Push { TestFillParams p; };
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= p.count) return;
  dst[i] = i + p.value_offset;
}
