#include "support/test_support.h"

#include "common/error.h"

#include <gtest/gtest.h>

#include <atomic>
#include <unistd.h>

#include <cstdlib>

namespace cofusion::test {
namespace fs = std::filesystem;

std::optional<fs::path> data_dir(const std::string& subdir) {
  const char* env = std::getenv("COFUSION_DATA");
  if (!env || !*env) return std::nullopt;
  fs::path p = fs::path(env) / subdir;
  std::error_code ec;
  if (!fs::is_directory(p, ec) && !fs::is_regular_file(p, ec)) return std::nullopt;
  return p;
}

fs::path fresh_temp_dir(const std::string& hint) {
  static std::atomic<int> counter{0};
  const char* env = std::getenv("COFUSION_TEST_TMP");
  fs::path root = env && *env ? fs::path(env) : fs::temp_directory_path() / "cofusion-tests";
  std::string name = hint;
  if (const auto* info = ::testing::UnitTest::GetInstance()->current_test_info())
    name = std::string(info->test_suite_name()) + "." + info->name() + (hint.empty() ? "" : "." + hint);
  for (char& c : name)
    if (c == '/') c = '_';
  fs::path dir = root / (name + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

fs::path cofusion_exe() {
  const char* env = std::getenv("COFUSION_EXE");
  return env ? fs::path(env) : fs::path("cofusion");
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

fs::path source_dir() {
  const char* env = std::getenv("COFUSION_SOURCE_DIR");
  return env ? fs::path(env) : fs::current_path();
}

}  // namespace cofusion::test
