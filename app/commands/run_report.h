#pragma once
// The report `cofusion run` prints when it ends: one row per model (id, class, state, surfels,
// first and last frame, its files and trajectory under the output folder) and the camera's
// accuracy when the input has ground truth. Every cell is one word, so that a script can split a
// row on whitespace.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace cofusion::commands {

struct ModelRow {
  int id = 0;
  std::string class_name;  // one word (class_name_token)
  std::string state;       // active | inactive
  std::size_t surfels = 0;
  int first_frame = 0, last_frame = 0;  // processed-frame indices, as in summary.json
  std::string files;       // e.g. models/model-2.{glb,ply}; "-" when none was written
  std::string trajectory;  // e.g. trajectories/model-2.txt; "-" for the background and when none
};

// The camera's absolute trajectory error against the input's ground truth (TUM's evaluate_ate.py).
struct CameraAccuracy {
  double ate_rmse_m = 0;
  std::size_t frames = 0;  // frames with a ground-truth pose that were compared
};

// The model table: a header line and one line per row, columns left-aligned and two spaces apart
// (numbers right-aligned). Ends with a newline.
std::string model_table(const std::vector<ModelRow>& rows);

// The files of model `id` among `written` (the paths write_models() returned), relative to
// `out_dir` and with their extensions folded: "models/model-2.{glb,ply}"; "-" when there are none.
std::string model_files_cell(const std::vector<std::filesystem::path>& written, const std::filesystem::path& out_dir,
                             int id);

// The lines under the table: where the paths are, the camera trajectory and the scene, and the camera ATE
// ("camera ATE 0.63 cm RMSE over 150 frames against the input's ground truth") when known.
std::string report_footer(const std::filesystem::path& out_dir, const std::optional<CameraAccuracy>& accuracy);

}  // namespace cofusion::commands
