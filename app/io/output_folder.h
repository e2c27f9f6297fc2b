#pragma once
// The output folder of a run: created (and checked writable) before the run, so a bad path fails
// early, and taken away again when the run ends before it has anything to write, so a run that
// fails before its first frame leaves no folder behind.
#include <filesystem>
#include <string>
#include <vector>

namespace cofusion {

class OutputFolder {
 public:
  // Creates `root` and root/<each of subfolders>, checking each is writable; throws
  // cofusion::Error naming the folder otherwise (removing what it created).
  OutputFolder(std::filesystem::path root, const std::vector<std::string>& subfolders);
  // Unless keep() was called: removes every folder this object created, with what is in it.
  // Folders that existed before are left as they were.
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  // From now on the folders stay (the run has output to write).
  void keep() { keep_ = true; }
  const std::filesystem::path& path() const { return root_; }

 private:
  void remove_created() noexcept;

  std::filesystem::path root_;
  std::vector<std::filesystem::path> created_;  // outermost first
  bool keep_ = false;
};

}  // namespace cofusion
