// open_source(): maps "scheme:path" on the command line to a FrameSource. Parsing and the
// recorded kinds live in io/source_spec.h; synthetic scenes come from the generator library.
#include "commands/sources.h"

#include "common/error.h"
#include "io/read_ahead_source.h"
#include "io/source_adaptors.h"
#include "io/source_spec.h"
#include "synthetic/synthetic_source.h"

namespace cofusion {

std::unique_ptr<FrameSource> open_source(const std::string& spec, const SourceOptions& options) {
  if (options.max_frames && *options.max_frames < 0)
    throw Error("input '" + spec + "': --max-frames must not be negative");
  if (options.read_ahead_frames < 0)
    throw Error("input '" + spec + "': frames read ahead must not be negative");
  const SourceSpec parsed = parse_source_spec(spec);
  std::unique_ptr<FrameSource> source;
  if (parsed.scheme == "synthetic") {
    if (!options.intrinsics.empty())
      throw Error("input '" + spec + "': --intrinsics does not apply to synthetic scenes (the scene sets its camera)");
    if (options.depth_correction)
      throw Error("input '" + spec + "': --depth-correction does not apply to synthetic scenes (their depth is metric)");
    source = synthetic::make_synthetic_source(parsed.path, options.seed, options.max_frames);
  } else {
    source = open_recorded_source(parsed, options.intrinsics, options.depth_correction);
  }
  // Every source honours max_frames, whether or not it could stop early by itself.
  if (options.max_frames) source = std::make_unique<LimitedSource>(std::move(source), *options.max_frames);
  // Outside the limit, so that the reader never reads past it.
  if (options.read_ahead_frames > 0 && parsed.scheme != "openni2")
    source = std::make_unique<ReadAheadSource>(std::move(source), options.read_ahead_frames);
  return source;
}

}  // namespace cofusion
