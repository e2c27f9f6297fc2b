#include "io/output_folder.h"

#include "common/error.h"
#include "io/atomic_file.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {
// The outermost folder of `dir` that does not exist yet (empty when `dir` exists).
fs::path outermost_missing(const fs::path& dir) {
  std::error_code ec;
  fs::path missing;
  for (fs::path p = fs::absolute(dir, ec); !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
    missing = p;
    if (p == p.parent_path()) break;
  }
  return missing;
}
}  // namespace

OutputFolder::OutputFolder(fs::path root, const std::vector<std::string>& subfolders) : root_(std::move(root)) {
  try {
    std::vector<fs::path> dirs{root_};
    for (const auto& sub : subfolders) dirs.push_back(root_ / sub);
    for (const auto& dir : dirs) {
      if (fs::path missing = outermost_missing(dir); !missing.empty()) created_.push_back(std::move(missing));
      ensure_writable_directory(dir);
    }
  } catch (...) {
    remove_created();
    throw;
  }
}

OutputFolder::~OutputFolder() {
  if (!keep_) remove_created();
}

void OutputFolder::remove_created() noexcept {
  for (const auto& dir : created_) {
    std::error_code ignored;
    fs::remove_all(dir, ignored);
  }
  created_.clear();
}

}  // namespace cofusion
