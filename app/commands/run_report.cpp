// The final report of `cofusion run`: the model table and the lines under it.
#include "commands/run_report.h"

#include <algorithm>
#include <array>
#include <cstdio>

namespace cofusion::commands {
namespace fs = std::filesystem;

namespace {

constexpr std::size_t kColumns = 8;
using Cells = std::array<std::string, kColumns>;
// Numeric columns are right-aligned.
constexpr std::array<bool, kColumns> kRightAligned{true, false, false, true, true, true, false, false};

Cells cells(const ModelRow& row) {
  return {std::to_string(row.id), row.class_name,
          row.state,              std::to_string(row.surfels),
          std::to_string(row.first_frame), std::to_string(row.last_frame),
          row.files,              row.trajectory};
}

std::string pad(const std::string& text, std::size_t width, bool right) {
  const std::string fill(width - std::min(width, text.size()), ' ');
  return right ? fill + text : text + fill;
}

}  // namespace

std::string model_table(const std::vector<ModelRow>& rows) {
  std::vector<Cells> lines{{"id", "class", "state", "surfels", "first", "last", "files", "trajectory"}};
  for (const auto& row : rows) lines.push_back(cells(row));
  std::array<std::size_t, kColumns> width{};
  for (const auto& line : lines)
    for (std::size_t c = 0; c < kColumns; ++c) width[c] = std::max(width[c], line[c].size());
  std::string out;
  for (const auto& line : lines) {
    std::string text;
    for (std::size_t c = 0; c < kColumns; ++c) {
      if (c > 0) text += "  ";
      // The last column is not padded: no trailing blanks.
      text += c + 1 < kColumns ? pad(line[c], width[c], kRightAligned[c]) : line[c];
    }
    out += text + "\n";
  }
  return out;
}

std::string model_files_cell(const std::vector<fs::path>& written, const fs::path& out_dir, int id) {
  const std::string stem = "model-" + std::to_string(id);
  fs::path folder;
  std::vector<std::string> extensions;
  for (const auto& path : written) {
    if (path.stem() != stem) continue;
    folder = path.lexically_relative(out_dir).parent_path();
    extensions.push_back(path.extension().string().substr(1));  // ".glb" -> "glb"
  }
  if (extensions.empty()) return "-";
  const std::string base = (folder / stem).string() + ".";
  if (extensions.size() == 1) return base + extensions[0];
  std::string joined;
  for (const auto& e : extensions) joined += (joined.empty() ? "" : ",") + e;
  return base + "{" + joined + "}";
}

std::string report_footer(const fs::path& out_dir, const std::optional<CameraAccuracy>& accuracy) {
  std::string out = "in " + out_dir.string() + ": the files above, trajectories/camera.txt, " +
                    "scene.glb (all models and the camera's path), summary.json\n";
  if (accuracy) {
    char line[160];
    std::snprintf(line, sizeof line, "camera ATE %.2f cm RMSE over %zu frames against the input's ground truth\n",
                  100.0 * accuracy->ate_rmse_m, accuracy->frames);
    out += line;
  }
  return out;
}

}  // namespace cofusion::commands
