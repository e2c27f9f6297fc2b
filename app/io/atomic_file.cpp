#include "io/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <utility>

#include "common/error.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {
fs::path temporary_name(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  return path.parent_path() / (path.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                               std::to_string(counter++));
}
}  // namespace

void write_atomically(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  const fs::path tmp = temporary_name(path);
  try {
    write(tmp);
    if (!fs::exists(tmp)) throw Error("nothing was written");
    fs::rename(tmp, path);
  } catch (const std::exception& e) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw Error("cannot write " + path.string() + ": " + e.what());
  }
}

void write_text_atomically(const fs::path& path, std::string_view text) {
  write_bytes_atomically(path, std::as_bytes(std::span(text.data(), text.size())));
}

void write_bytes_atomically(const fs::path& path, std::span<const std::byte> bytes) {
  write_atomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error("cannot open " + tmp.string() + " for writing");
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) throw Error("write failed (disk full?)");
  });
}

void ensure_writable_directory(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create output directory " + dir.string() + ": " + ec.message());
  const fs::path probe = temporary_name(dir / ".write-probe");
  {
    std::ofstream out(probe);
    if (!out) throw Error("output directory " + dir.string() + " is not writable");
  }
  fs::remove(probe, ec);
}

PendingFile::PendingFile(fs::path path) : path_(std::move(path)), tmp_path_(temporary_name(path_)) {}

PendingFile::~PendingFile() {
  if (committed_) return;
  std::error_code ignored;
  fs::remove(tmp_path_, ignored);
}

void PendingFile::commit() {
  if (committed_) return;
  std::error_code ec;
  if (!fs::exists(tmp_path_, ec)) throw Error("cannot write " + path_.string() + ": nothing was written");
  fs::rename(tmp_path_, path_, ec);
  if (ec) throw Error("cannot write " + path_.string() + ": " + ec.message());
  committed_ = true;
}

}  // namespace cofusion
