#include "io/source_spec.h"

#include <filesystem>
#include <system_error>

#include "common/error.h"
#include "io/image_folder_source.h"
#include "io/klg.h"
#include "io/live_source.h"
#include "io/openni_source.h"
#include "io/source_adaptors.h"
#include "io/tum_source.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {

constexpr const char* kSchemes = "synthetic[:SCENE], tum:PATH, klg:PATH, oni:PATH, openni2[:URI], images:PATH";

std::string scheme_of_bare_path(const std::string& spec) {
  std::error_code ec;
  const fs::path p(spec);
  if (fs::is_regular_file(p, ec)) {
    if (p.extension() == ".klg") return "klg";
    if (p.extension() == ".oni") return "oni";
  } else if (fs::is_directory(p, ec)) {
    if (fs::exists(p / "associations.txt", ec) || fs::exists(p / "rgb.txt", ec)) return "tum";
    if (fs::is_directory(p / "depth", ec)) return "images";
  }
  return "";
}

}  // namespace

SourceSpec parse_source_spec(const std::string& spec) {
  if (spec.empty()) throw Error("input: no source given; expected one of " + std::string(kSchemes));
  const auto colon = spec.find(':');
  if (colon == std::string::npos) {
    if (spec == "synthetic" || spec == "openni2") return {spec, ""};
    const std::string scheme = scheme_of_bare_path(spec);
    if (scheme.empty())
      throw Error("input '" + spec + "': not a source; expected one of " + std::string(kSchemes) +
                  " (or an existing .klg/.oni file, TUM folder or image folder)");
    return {scheme, spec};
  }
  SourceSpec out{spec.substr(0, colon), spec.substr(colon + 1)};
  const bool needs_path = out.scheme == "tum" || out.scheme == "klg" || out.scheme == "oni" || out.scheme == "images";
  if (!needs_path && out.scheme != "synthetic" && out.scheme != "openni2")
    throw Error("input '" + spec + "': unknown source scheme '" + out.scheme + "'; expected one of " +
                std::string(kSchemes));
  if (needs_path && out.path.empty()) throw Error("input '" + spec + "': missing path after '" + out.scheme + ":'");
  return out;
}

std::unique_ptr<FrameSource> open_recorded_source(const SourceSpec& spec, const std::string& intrinsics,
                                                  std::optional<double> depth_correction) {
  if (spec.scheme == "tum") {
    TumSourceOptions o;
    o.intrinsics = intrinsics;
    o.depth_correction = depth_correction;
    return std::make_unique<TumSource>(spec.path, o);
  }
  std::unique_ptr<FrameSource> source;
  if (spec.scheme == "klg") {
    KlgSourceOptions o;
    o.intrinsics = intrinsics;
    source = std::make_unique<KlgSource>(spec.path, o);
  } else if (spec.scheme == "images") {
    ImageFolderSourceOptions o;
    o.intrinsics = intrinsics;
    source = std::make_unique<ImageFolderSource>(spec.path, o);
  } else if (spec.scheme == "oni" || spec.scheme == "openni2") {
    OpenNiSourceOptions o;
    o.intrinsics = intrinsics;
    if (spec.scheme == "oni")
      source = OpenNiSource::open_recording(spec.path, o);
    else  // a live device: the pipeline takes the newest frame, those arriving while it is busy are dropped
      source = std::make_unique<LiveSource>(OpenNiSource::open_device(spec.path, o));
  } else {
    throw Error("input '" + spec.scheme + ":" + spec.path + "': '" + spec.scheme + "' is not a recorded source");
  }
  if (depth_correction) source = std::make_unique<DepthCorrectedSource>(std::move(source), *depth_correction);
  return source;
}

}  // namespace cofusion
