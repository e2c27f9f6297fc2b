// The run's output folder: removed again with what it holds unless kept; folders that were there
// before are left alone.
#include "io/output_folder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;

TEST(OutputFolder, RemovesWhatItCreatedUnlessKept) {
  const fs::path base = test::fresh_temp_dir();
  {
    OutputFolder folder(base / "a" / "out", {"trajectories", "segmentation"});
    EXPECT_TRUE(fs::is_directory(base / "a" / "out" / "trajectories"));
    EXPECT_TRUE(fs::is_directory(base / "a" / "out" / "segmentation"));
    test::write_text(base / "a" / "out" / "trajectories" / "camera.txt", "");
  }
  EXPECT_FALSE(fs::exists(base / "a")) << "the outermost folder it created is gone";
  {
    OutputFolder folder(base / "kept", {"trajectories"});
    folder.keep();
  }
  EXPECT_TRUE(fs::is_directory(base / "kept" / "trajectories"));
}

TEST(OutputFolder, LeavesFoldersThatExistedBefore) {
  const fs::path out = test::fresh_temp_dir();
  test::write_text(out / "notes.txt", "mine");
  { OutputFolder folder(out, {"trajectories"}); }
  EXPECT_TRUE(fs::exists(out / "notes.txt"));
  EXPECT_FALSE(fs::exists(out / "trajectories"));
}

TEST(OutputFolder, UnwritablePathFailsNamingItAndLeavesNothing) {
  const fs::path base = test::fresh_temp_dir();
  test::write_text(base / "a-file", "");
  EXPECT_THAT(test::error_of([&] { OutputFolder folder(base / "a-file" / "out", {"trajectories"}); }),
              ::testing::HasSubstr((base / "a-file" / "out").string()));
  std::vector<fs::path> left;
  for (const auto& e : fs::directory_iterator(base)) left.push_back(e.path().filename());
  EXPECT_EQ(left, std::vector<fs::path>{"a-file"});
}

}  // namespace
}  // namespace cofusion
