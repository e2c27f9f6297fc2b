#pragma once
// Output files are written to a temporary name beside the target and renamed into place, so a
// failed or interrupted run never leaves a half-written file under the final name.
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <string_view>

namespace cofusion {

// Calls write(tmp_path) to produce the file, then renames tmp_path to path. On any exception the
// temporary is removed and a cofusion::Error naming `path` is thrown.
void write_atomically(const std::filesystem::path& path,
                      const std::function<void(const std::filesystem::path& tmp_path)>& write);

void write_text_atomically(const std::filesystem::path& path, std::string_view text);
void write_bytes_atomically(const std::filesystem::path& path, std::span<const std::byte> bytes);

// Creates `dir` (and parents) and checks that a file can be created in it; throws cofusion::Error
// naming the directory otherwise. Call before a long run so an unwritable output fails early.
void ensure_writable_directory(const std::filesystem::path& dir);

// For writers that stream a file over many calls (e.g. a log written frame by frame): write to
// tmp_path(), then commit() renames it to the final path. Destroying an uncommitted PendingFile
// removes the temporary, so an interrupted or failed writer leaves nothing under the final name.
class PendingFile {
 public:
  explicit PendingFile(std::filesystem::path path);
  ~PendingFile();
  PendingFile(const PendingFile&) = delete;
  PendingFile& operator=(const PendingFile&) = delete;

  const std::filesystem::path& path() const { return path_; }
  const std::filesystem::path& tmp_path() const { return tmp_path_; }
  bool committed() const { return committed_; }
  // Renames the temporary into place; throws cofusion::Error naming path() on failure.
  void commit();

 private:
  std::filesystem::path path_;
  std::filesystem::path tmp_path_;
  bool committed_ = false;
};

}  // namespace cofusion
