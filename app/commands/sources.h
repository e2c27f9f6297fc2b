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
  // Frames (bad ones included) read and decoded ahead of the caller on a thread of their own, so
  // that reading files overlaps the pipeline's work; 0 = read when asked. Not for the live
  // openni2 source, which has its own reader thread (newest frame wins). `cofusion run` uses
  // kRunReadAheadFrames: a few frames cover the jitter of file reads, each 640x480 frame holds
  // about 2.8 MB (colour, depth in metres, mask).
  int read_ahead_frames = 0;
  static constexpr int kRunReadAheadFrames = 4;
};

// Throws cofusion::Error with a one-line reason (unknown scheme, missing path, bad intrinsics ...).
std::unique_ptr<FrameSource> open_source(const std::string& spec, const SourceOptions& options);

}  // namespace cofusion
