// The report `cofusion run` ends with: the model table, the files cell and the lines under it.
#include "commands/run_report.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

namespace cofusion::commands {
namespace {
using ::testing::HasSubstr;
using ::testing::Not;

std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

std::vector<std::string> lines(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

TEST(RunReport, TableHasAHeaderAndOneAlignedRowPerModelOfOneWordCells) {
  const std::vector<ModelRow> rows{
      {0, "background", "active", 123456, 0, 149, "models/model-0.{glb,ply}", "-"},
      {12, "box", "inactive", 987, 40, 101, "models/model-12.{glb,ply}", "trajectories/model-12.txt"}};
  const std::vector<std::string> table = lines(model_table(rows));
  ASSERT_EQ(table.size(), 3u);
  EXPECT_EQ(words(table[0]),
            (std::vector<std::string>{"id", "class", "state", "surfels", "first", "last", "files", "trajectory"}));
  EXPECT_EQ(words(table[1]), (std::vector<std::string>{"0", "background", "active", "123456", "0", "149",
                                                        "models/model-0.{glb,ply}", "-"}));
  EXPECT_EQ(words(table[2]), (std::vector<std::string>{"12", "box", "inactive", "987", "40", "101",
                                                        "models/model-12.{glb,ply}", "trajectories/model-12.txt"}));
  // Aligned: every column starts at the same position in every line (text columns left-aligned,
  // numbers right-aligned, so the "files" column is the one to compare).
  const size_t files = table[0].find("files");
  EXPECT_EQ(table[1].find("models/"), files);
  EXPECT_EQ(table[2].find("models/"), files);
  EXPECT_EQ(table[1].find("background"), table[0].find("class"));
  for (const auto& line : table) EXPECT_NE(line.back(), ' ') << "no trailing blanks: '" << line << "'";
}

TEST(RunReport, FilesCellFoldsTheModelsFilesAndIgnoresOthers) {
  const std::filesystem::path out = "/out";
  const std::vector<std::filesystem::path> written{"/out/models/model-1.glb", "/out/models/model-1.ply",
                                                   "/out/models/model-10.glb", "/out/scene.glb"};
  EXPECT_EQ(model_files_cell(written, out, 1), "models/model-1.{glb,ply}");
  EXPECT_EQ(model_files_cell(written, out, 10), "models/model-10.glb");
  EXPECT_EQ(model_files_cell(written, out, 2), "-");
  EXPECT_EQ(model_files_cell({}, out, 0), "-");
}

TEST(RunReport, FooterGivesTheCameraAteOnlyWhenKnown) {
  EXPECT_THAT(report_footer("out", std::nullopt), Not(HasSubstr("ATE")));
  EXPECT_THAT(report_footer("out", CameraAccuracy{0.00634, 150}),
              HasSubstr("camera ATE 0.63 cm RMSE over 150 frames against the input's ground truth"));
  EXPECT_THAT(report_footer("out", std::nullopt), HasSubstr("trajectories/camera.txt"));
}

}  // namespace
}  // namespace cofusion::commands
