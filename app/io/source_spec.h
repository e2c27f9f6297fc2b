#pragma once
// The input named on the command line, "scheme:path" (see commands/sources.h for the list), and
// opening the recorded kinds of it. Synthetic scenes are opened by commands/sources.cpp, which
// owns the dependency on the scene generator.
#include <memory>
#include <optional>
#include <string>

#include "io/frame.h"

namespace cofusion {

struct SourceSpec {
  std::string scheme;  // synthetic, tum, klg, oni, openni2, images
  std::string path;    // path, scene name or URI after the colon; may be empty for synthetic/openni2
};

// "tum:/data/x" -> {tum, /data/x}; "synthetic" and "openni2" stand alone; a bare existing path
// names its kind (.klg, .oni, a TUM folder with rgb.txt/associations.txt, an image folder with
// depth/). Throws cofusion::Error quoting `spec` for an unknown scheme or a missing path.
SourceSpec parse_source_spec(const std::string& spec);

// Opens tum, klg, oni, openni2 and images specs with the --intrinsics option (may be empty) and
// the --depth-correction option (recorded depth / it = metric depth; empty: TUM folders of a TUM
// camera apply that camera's correction, other sources none).
// Throws cofusion::Error for the synthetic scheme (not an I/O source) and for bad input.
std::unique_ptr<FrameSource> open_recorded_source(const SourceSpec& spec, const std::string& intrinsics,
                                                  std::optional<double> depth_correction = std::nullopt);

}  // namespace cofusion
