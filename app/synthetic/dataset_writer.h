#pragma once
// Writes a synthetic sequence to disk as a TUM RGB-D folder (io/tum_writer.h) plus the extra
// ground truth:
//   rgb/<t>.png  depth/<t>.png (16-bit, 5000 units per metre)  masks/<t>.png (16-bit instance ids)
//   masks/classes.txt (id class_name: each object's "class")
//   rgb.txt  depth.txt  associations.txt  groundtruth.txt (T_world_camera)
//   groundtruth-<id>.txt (T_world_object, frames where object <id> is present; a person's pelvis)
//   objects.txt (id name shape first_frame last_frame; shape "person" for people)
//   calibration.txt (fx fy cx cy width height)
//   geometry/background.glb (world frame)  geometry/object-<id>.glb (object frame; people standing
//   at rest)  scene.json
// <t> is the frame's timestamp in seconds with 6 decimals (frame / fps).
// Everything is written into a temporary sibling folder that is renamed to the target at the end,
// so a failed run leaves no partial output under the target name.
#include <filesystem>
#include <functional>

#include "synthetic/synthetic_source.h"

namespace cofusion::synthetic {

struct DatasetOptions {
  bool overwrite = false;  // replace an existing non-empty target folder (otherwise an error)
  // Called after each frame is written, with the number done and the total (one call at a time,
  // from a worker thread).
  std::function<void(int done, int total)> progress;
};

inline constexpr double kTumDepthUnitsPerMetre = 5000.0;

void write_tum_dataset(const SyntheticSequence& sequence, const std::filesystem::path& out_dir,
                       const DatasetOptions& options = {});

}  // namespace cofusion::synthetic
