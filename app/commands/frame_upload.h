#pragma once
// Moves a host Frame into a FramePyramid's input buffers.
#include "gpu/stream.h"
#include "io/frame.h"
#include "kernels/preprocess.h"

namespace cofusion::commands {

inline constexpr float kUploadMetresPerUnit = kernels::FramePyramid::kUploadMetresPerUnit;

// Checks the frame against the pyramid's size (error names the frame) and uploads depth and RGB.
void upload_frame(gpu::Stream& stream, const Frame& frame, kernels::FramePyramid& pyramid);

// A deterministic built-in RGB-D frame (a room corner, a box and a sphere, textured), used by
// the benchmark when no input is given.
Frame make_builtin_test_frame(const Intrinsics& intrinsics);

}  // namespace cofusion::commands
