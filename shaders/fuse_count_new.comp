#version 460
// First pass of fusion's new-surfel compaction (host_device.h): per block of COMPACTION_BLOCK
// pixels of the rectangle (row-major), the number of pixels that spawn a new surfel (association
// FUSE_NO_SURFEL). compaction_scan turns the counts into the blocks' first slots for fuse_update.
#extension GL_GOOGLE_include_directive : require
#include "shared/host_device.h"
#include "shared/texel_access.glsl"
#include "shared/compaction.glsl"
#include "shared/fuse_rect.glsl"
layout(local_size_x = COMPACTION_BLOCK) in;
layout(binding = FUSE_BINDING_ASSOC) uniform usamplerBuffer assoc;  // texel view of uint
layout(std430, binding = FUSE_BINDING_BLOCKS) writeonly buffer Blocks { uint blocks[]; };
layout(push_constant) uniform Push { FuseParams p; };
void main() {
  uvec2 px;
  const bool spawns = fuse_rect_pixel(p, gl_GlobalInvocationID.x, px) &&
                      texel_uint(assoc, px.y * p.width + px.x) == FUSE_NO_SURFEL;
  uint block_total;
  compaction_rank(spawns, block_total);
  if (gl_LocalInvocationIndex == 0u) blocks[gl_WorkGroupID.x] = block_total;
}
