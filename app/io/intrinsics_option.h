#pragma once
// Where a source's intrinsics come from: the --intrinsics option ("fx,fy,cx,cy[,w,h]", a preset
// name or a calibration file), a calibration file beside the data, or a preset guessed from the
// folder name. Each choice remembers its origin so describe() can say which was used.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "common/intrinsics.h"

namespace cofusion {

struct IntrinsicsChoice {
  Intrinsics intrinsics;
  // True when width/height were given (preset, 6-number option or file); otherwise the reader
  // takes the image size from its first frame and the 640x480 default only stands in until then.
  bool size_known = false;
  std::string origin;  // for the terminal, e.g. "fr2 preset (guessed from the path)"
  // The TUM preset the intrinsics came from ("fr1", "fr2", "fr3"), empty otherwise: a TUM folder
  // recorded by that camera applies its depth correction (tum_depth_correction).
  std::string tum_preset;
};

// Presets of the TUM RGB-D cameras and the PrimeSense factory default, all 640x480:
//   fr1 517.3 516.5 318.6 255.3 | fr2 520.9 521.0 325.1 249.7 | fr3 535.4 539.2 320.1 247.6 |
//   primesense 525 525 319.5 239.5. "freiburg1".."freiburg3" are accepted as aliases.
std::optional<Intrinsics> intrinsics_preset(std::string_view name);

// The depth correction "ds" that the TUM benchmark's calibration table lists beside each camera's
// intrinsics: fr1 1.035, fr2 1.031, fr3 1.000 (freiburg3's depth was corrected before release).
// Recorded depth / ds = metric depth: the fr1/fr2 Kinects read a few percent long (two independent
// trackers measure fr2/desk 4% larger than its ground truth, 1.1% after this correction).
// nullopt for names that are not TUM cameras (primesense included).
std::optional<double> tum_depth_correction(std::string_view preset);

// The colour camera's rolling-shutter readout (slam::RollingShutterParams::colour_readout_s) of
// a TUM camera, rows read from the top down: fr1 0.02 s (two thirds of a 30 Hz frame; measured on
// fr1/rpy's fast turns, docs/experiments.md). 0 for fr2 (on fr2/desk it made the camera worse)
// and fr3 (not measured), and for other names.
double tum_colour_readout_s(std::string_view preset);

// Throws cofusion::Error "<where>: --depth-correction must be between 0.5 and 2 ..." otherwise.
void require_plausible_depth_correction(double depth_correction, const std::string& where);
// " depth / 1.031 (<origin>)", as the sources' describe() show a correction.
std::string depth_correction_label(double depth_correction, const std::string& origin);

// A calibration file holding "fx fy cx cy [w h]" (whitespace separated, '#' comments allowed).
// Throws cofusion::Error naming the file when it is missing, malformed or implausible.
IntrinsicsChoice read_calibration_file(const std::filesystem::path& path);

// The --intrinsics option: "fx,fy,cx,cy" or "fx,fy,cx,cy,w,h", a preset name, or a calibration
// file path. Throws cofusion::Error quoting the option when it is none of those or implausible.
IntrinsicsChoice parse_intrinsics_option(const std::string& option);

// The TUM preset named by a folder path ("freiburg2" or "fr2" as a word in any component, the
// deepest component first), e.g. "rgbd_dataset_freiburg1_rpy" -> "fr1".
std::optional<std::string> guess_tum_preset(const std::filesystem::path& folder);

// Throws cofusion::Error "<where>: implausible intrinsics ..." unless k.plausible().
void require_plausible(const Intrinsics& k, const std::string& where);

}  // namespace cofusion
