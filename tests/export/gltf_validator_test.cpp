// Runs the exported files through the Khronos glTF validator (npm `gltf-validator`, driven by
// tests/export/validate_gltf.mjs). tests/CMakeLists.txt installs the package into the build tree
// and sets GLTF_VALIDATOR_DIR; without that variable (the executable run by hand) the test skips,
// but with it a missing node or package is a failure, not a skip.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "export/export_test_util.h"
#include "export/model_export.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (const char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

struct CommandResult {
  int exit_code = -1;
  std::string output;
};

CommandResult run_command(const std::string& command) {
  CommandResult result;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) result.output.append(buffer, n);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

// Validates `files`; returns the script's exit code and output. Fails the test (returns nullopt)
// when node or the package is missing.
std::optional<CommandResult> validate(const std::vector<fs::path>& files) {
  const fs::path script = test::source_dir() / "tests/export/validate_gltf.mjs";
  EXPECT_TRUE(fs::exists(script)) << script << " not found (is COFUSION_SOURCE_DIR set?)";
  const CommandResult node = run_command("node --version");
  if (node.exit_code != 0) {
    ADD_FAILURE() << "node is not on PATH (the install script provides nodejs): " << node.output;
    return std::nullopt;
  }
  std::string command = "node " + shell_quote(script.string()) + " --fail-on-warnings";
  for (const fs::path& f : files) command += " " + shell_quote(f.string());
  CommandResult result = run_command(command);
  if (result.exit_code == 2) {
    ADD_FAILURE() << "the glTF validator could not run (GLTF_VALIDATOR_DIR=" << std::getenv("GLTF_VALIDATOR_DIR")
                  << "; built by the gltf_validator target):\n"
                  << result.output;
    return std::nullopt;
  }
  return result;
}

bool validator_configured() { return std::getenv("GLTF_VALIDATOR_DIR") != nullptr; }

TEST(GltfValidator, ExportedFilesHaveNoErrorsOrWarnings) {
  if (!validator_configured()) GTEST_SKIP() << "GLTF_VALIDATOR_DIR not set: run through ctest";
  const fs::path dir = test::fresh_temp_dir();

  std::vector<SurfelCloud> models = {test::sample_model(0, 500), test::sample_model(1, 200, "cup"),
                                     test::sample_model(2, 0, "empty"), test::sample_model(3, 50)};
  models[0].T_world_model = Eigen::Isometry3d::Identity();  // written without a matrix
  models[3].surfels[0].nx = models[3].surfels[0].ny = models[3].surfels[0].nz = 0.0f;  // must be dropped
  Trajectory camera;
  for (int i = 0; i < 20; ++i) {
    TimedPose p;
    p.T_world_x = test::sample_pose(0.05 * i);
    p.T_world_x.translation() = Eigen::Vector3d(0.03 * i, 0.1 * std::sin(0.3 * i), 0.0);
    camera.push_back(p);
  }
  camera.push_back(camera.back());  // a stationary camera repeats a position
  std::vector<fs::path> files = write_models(models, camera, dir / "glb", {.min_confidence = 1.0f});
  const auto gltf_files = write_models(models, camera, dir / "gltf", {.gltf_container = GltfContainer::GltfPlusBin});
  files.insert(files.end(), gltf_files.begin(), gltf_files.end());
  std::erase_if(files, [](const fs::path& p) { return p.extension() == ".ply"; });
  ASSERT_EQ(files.size(), 10u);

  const auto result = validate(files);
  ASSERT_TRUE(result);
  EXPECT_EQ(result->exit_code, 0) << result->output;
  // One summary line per file, each clean.
  for (const fs::path& f : files)
    EXPECT_NE(result->output.find(f.string() + ": 0 errors, 0 warnings"), std::string::npos) << result->output;
}

// The harness itself must catch a broken file, or the test above proves nothing.
TEST(GltfValidator, ReportsErrorsInABrokenFile) {
  if (!validator_configured()) GTEST_SKIP() << "GLTF_VALIDATOR_DIR not set: run through ctest";
  const fs::path dir = test::fresh_temp_dir();
  // A POSITION accessor without min/max (an error in glTF 2.0), its 12-byte buffer inline.
  std::ofstream(dir / "broken.gltf") << R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
    "nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"mode":0}]}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":1,"type":"VEC3"}],
    "bufferViews":[{"buffer":0,"byteLength":12}],
    "buffers":[{"byteLength":12,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAA"}]})";
  const auto result = validate({dir / "broken.gltf"});
  ASSERT_TRUE(result);
  EXPECT_EQ(result->exit_code, 1) << result->output;
  EXPECT_NE(result->output.find("MESH_PRIMITIVE_POSITION_ACCESSOR_WITHOUT_BOUNDS"), std::string::npos)
      << result->output;
}

}  // namespace
}  // namespace cofusion
