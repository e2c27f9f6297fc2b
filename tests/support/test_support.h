#pragma once
// Helpers shared by every test suite: where the real recordings are, fresh temporary folders.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace cofusion::test {

// ../shared/data (or $COFUSION_DATA) when it exists and holds `subdir`; std::nullopt otherwise.
// Use with GTEST_SKIP() << "..." so the suite passes on machines without the recordings.
std::optional<std::filesystem::path> data_dir(const std::string& subdir = "");

// A new, empty folder under the build tree's test tmp area (or the system temp dir), unique per
// call; named after the current test.
std::filesystem::path fresh_temp_dir(const std::string& hint = "");

// Path of the built `cofusion` executable ($COFUSION_EXE), for end-to-end tests.
std::filesystem::path cofusion_exe();

// The message of the cofusion::Error that `f` throws, or "(no error)" when it throws none.
std::string error_of(const std::function<void()>& f);

// Source tree root ($COFUSION_SOURCE_DIR), for tests that read assets/.
std::filesystem::path source_dir();

}  // namespace cofusion::test
