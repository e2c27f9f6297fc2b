// End-to-end: `cofusion detect` on the fr2/desk recording writes masks/ named like the colour
// images and a class table covering every id; a missing model folder fails with the fix.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <opencv2/imgcodecs.hpp>

#include "support/test_support.h"

namespace cofusion::test {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct Result {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

Result run_detect(const std::string& args) {
  const std::string command = cofusion_exe().string() + " detect " + args + " 2>&1";
  Result r;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buffer{};
  while (size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe)) r.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

TEST(DetectCommand, WritesMasksAndClassesForTumFr2Desk) {
  const char* models = std::getenv("COFUSION_MODELS");
  if (!models || !fs::is_regular_file(fs::path(models) / "centernet.pb") ||
      !fs::is_regular_file(fs::path(models) / "selfie.pb"))
    GTEST_SKIP() << "no converted models in $COFUSION_MODELS: run .ci/fetch-models.sh";
  const auto data = data_dir("tum_fr2_desk_50");
  if (!data) GTEST_SKIP() << "tum_fr2_desk_50 not in $COFUSION_DATA";
  const fs::path out = fresh_temp_dir();
  const Result r = run_detect("--input tum:" + data->string() + " --output " + out.string() + " --max-frames 2");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("detector forward pass"));

  std::map<int, std::string> classes;
  std::ifstream in(out / "masks" / "classes.txt");
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    int id = 0;
    std::string name, extra;
    ASSERT_TRUE(ls >> id >> name) << line;
    EXPECT_FALSE(ls >> extra) << "one word per class name: " << line;
    EXPECT_TRUE(classes.emplace(id, name).second) << "id given twice: " << line;
  }
  std::set<std::string> names;
  for (const auto& [id, name] : classes) names.insert(name);
  EXPECT_TRUE(names.count("keyboard")) << "the desk's keyboard";
  EXPECT_TRUE(names.count("tvmonitor")) << "and monitor";

  // Two masks, named like the first two colour images, every id in the class table.
  std::vector<fs::path> rgb;
  for (const auto& e : fs::directory_iterator(*data / "rgb")) rgb.push_back(e.path());
  std::sort(rgb.begin(), rgb.end());
  int mask_files = 0;
  for (const auto& e : fs::directory_iterator(out / "masks")) mask_files += e.path().extension() == ".png";
  EXPECT_EQ(mask_files, 2);
  std::set<int> seen;
  for (int i = 0; i < 2; ++i) {
    const fs::path mask_path = out / "masks" / (rgb[static_cast<size_t>(i)].stem().string() + ".png");
    const cv::Mat mask = cv::imread(mask_path.string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(mask.empty()) << mask_path;
    ASSERT_EQ(mask.type(), CV_16UC1);
    EXPECT_EQ(mask.size(), cv::Size(640, 480));
    for (int y = 0; y < mask.rows; ++y)
      for (int x = 0; x < mask.cols; ++x)
        if (const int id = mask.at<uint16_t>(y, x); id != 0 && seen.insert(id).second) {
          EXPECT_TRUE(classes.count(id)) << mask_path << ": id " << id << " has no class";
        }
  }
  EXPECT_EQ(seen.size(), classes.size()) << "every listed id is used";
}

TEST(DetectCommand, MissingModelsNameTheFix) {
  const fs::path out = fresh_temp_dir();
  const Result r = run_detect("--input synthetic --models /nonexistent --output " + out.string() + " --max-frames 1");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("/nonexistent/centernet.pb"));
  EXPECT_THAT(r.output, HasSubstr(".ci/fetch-models.sh"));
}

}  // namespace
}  // namespace cofusion::test
