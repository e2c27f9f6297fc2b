#pragma once
// Opens the frame source named on the command line:
//   synthetic[:SCENE]  built-in scene name or path to a scene .json (default: the default scene)
//   tum:PATH           TUM RGB-D folder
//   klg:PATH           Kintinuous / ElasticFusion / Co-Fusion log
//   oni:PATH           OpenNI recording (OpenNI2 file driver)
//   openni2[:URI]      live OpenNI2 device (first found, or URI)
//   images:PATH        colour/depth(/mask) image folders with a calibration file
#include <memory>
#include <optional>
#include <string>

#include "common/intrinsics.h"
#include "io/frame.h"

namespace cofusion {

struct SourceOptions {
  // --intrinsics "fx,fy,cx,cy", a calibration file path, or a preset name (fr1, fr2, fr3, primesense).
  std::string intrinsics;
  // --depth-correction: recorded depth / this = metric depth. Empty: a TUM folder recorded by a TUM
  // camera (fr1/fr2 preset, named or guessed) applies the benchmark's listed correction; others none.
  std::optional<double> depth_correction;
  std::optional<int> max_frames;  // stop after this many frames
  unsigned seed = 0;              // synthetic scenes: noise seed override (0 = the scene's own)
};

// Throws cofusion::Error with a one-line reason (unknown scheme, missing path, bad intrinsics ...).
std::unique_ptr<FrameSource> open_source(const std::string& spec, const SourceOptions& options);

}  // namespace cofusion
