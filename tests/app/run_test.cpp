// End-to-end: the `cofusion` executable on generated scenes and on the TUM recordings, with
// camera ATE against ground truth asserted, plus the command-line contract on bad input.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "eval/report.h"
#include "eval/trajectory_metrics.h"
#include "io/trajectory.h"
#include "support/test_support.h"
#include "synthetic/synthetic_source.h"

namespace cofusion::test {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

struct Result {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

// Runs a shell command; stdout and stderr together.
Result run_shell(const std::string& command_line) {
  const std::string command = command_line + " 2>&1";
  Result r;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buffer{};
  while (size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe)) r.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

Result run_cofusion(const std::string& args) { return run_shell(cofusion_exe().string() + " " + args); }

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

double camera_ate_m(const Trajectory& gt, const fs::path& out) {
  return eval::compute_ate(gt, read_tum_trajectory(out / "trajectories" / "camera.txt")).translation_m.rmse;
}

// A complete run's outputs: every frame, the stages, `models` models (the background first).
void expect_complete_output(const fs::path& out, int frames, size_t models = 1) {
  const auto summary = read_json(out / "summary.json");
  EXPECT_EQ(summary["frames"].get<int>(), frames);
  EXPECT_GT(summary["fps"].get<double>(), 0.0);
  EXPECT_FALSE(summary["device"].get<std::string>().empty());
  for (const char* stage : {"preprocess", "predict", "track", "fuse"}) EXPECT_TRUE(summary["stages_ms"].contains(stage)) << stage;
  ASSERT_EQ(summary["models"].size(), models);
  EXPECT_GT(summary["models"][0]["surfels"].get<int>(), 10000);
  EXPECT_TRUE(summary["tracking_failures"].empty()) << summary["tracking_failures"].dump();
  EXPECT_EQ(read_tum_trajectory(out / "trajectories" / "camera.txt").size(), size_t(frames));
  for (const char* f : {"models/model-0.glb", "models/model-0.ply", "scene.glb"}) EXPECT_TRUE(fs::exists(out / f)) << f;
  for (const auto& entry : fs::recursive_directory_iterator(out))
    EXPECT_THAT(entry.path().filename().string(), ::testing::Not(HasSubstr(".tmp-"))) << "temporary file left behind";
}

// Lines of a text file that are neither empty nor comments.
std::vector<std::string> data_lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') out.push_back(line);
  return out;
}

// segmentation/classes.txt lists every model of summary.json as "id class" (one word per class).
void expect_classes_of_summary_models(const fs::path& out) {
  const auto summary = read_json(out / "summary.json");
  std::vector<std::string> expected;
  for (const auto& m : summary["models"]) {
    std::string class_name = m["class"].get<std::string>();
    std::replace(class_name.begin(), class_name.end(), ' ', '_');
    expected.push_back(std::to_string(m["id"].get<int>()) + " " + class_name);
  }
  EXPECT_EQ(data_lines(out / "segmentation" / "classes.txt"), expected) << summary["models"].dump();
}

TEST(RunCommand, SaveSegmentationWritesTheModelsClasses) {
  const fs::path out = fresh_temp_dir();
  const Result r = run_cofusion(
      "run --headless --input synthetic:static_room --save-segmentation --max-frames 2 --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(data_lines(out / "segmentation" / "classes.txt"), std::vector<std::string>{"0 background"});
  expect_classes_of_summary_models(out);
  // The background model's glTF node carries its class in its name.
  std::ifstream glb(out / "models" / "model-0.glb", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(glb)), std::istreambuf_iterator<char>());
  EXPECT_NE(bytes.find("\"model-0-background\""), std::string::npos);
}

// Semantic segmentation with the scene's own masks: table_placement's box, carried in, becomes a
// model of class box (spawned at frame 24 of it); summary.json and classes.txt say so.
TEST(RunCommand, SemanticSegmentationNamesTheCarriedInBox) {
  const fs::path out = fresh_temp_dir();
  const Result r = run_cofusion("run --headless --input synthetic:table_placement --segmentation semantic --classes box,can "
                                "--save-segmentation --max-frames 30 --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto summary = read_json(out / "summary.json");
  EXPECT_EQ(summary["semantic"]["segmentation"], "semantic");
  EXPECT_EQ(summary["semantic"]["source"], "masks");
  ASSERT_EQ(summary["models"].size(), 2u) << summary["models"].dump();
  EXPECT_EQ(summary["models"][1]["class"], "box");
  EXPECT_GT(summary["models"][1]["class_confidence"].get<double>(), 0.5);
  expect_classes_of_summary_models(out);
}

TEST(RunCommand, BadSemanticOptionsFail) {
  const fs::path out = fresh_temp_dir();
  for (const char* args : {"--segmentation colour", "--semantic-source camera", "--exclude 'two words'"}) {
    const Result r = run_cofusion(std::string("run --headless --input synthetic:static_room --max-frames 1 ") + args +
                                  " --output " + out.string());
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_THAT(r.output, HasSubstr(std::string(args).substr(2, std::string(args).find(' ') - 2))) << r.output;
  }
  // The detector needs its models; asked for explicitly, a missing one is an error naming the file.
  const Result r = run_shell("COFUSION_MODELS=" + (out / "none").string() + " " + cofusion_exe().string() +
                             " run --headless --input synthetic:static_room --max-frames 1 --semantic-source detector --output " +
                             out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("centernet.pb")) << r.output;
}

TEST(GenerateCommand, WritesEachObjectsClassBesideTheMasks) {
  const fs::path out = fresh_temp_dir() / "two";
  const Result g = run_cofusion("generate two_objects --no-noise --max-frames 1 --output " + out.string());
  ASSERT_EQ(g.exit_code, 0) << g.output;
  EXPECT_EQ(data_lines(out / "masks" / "classes.txt"), (std::vector<std::string>{"1 box", "2 can"}));

  // A scene object without a class fails, naming the file and the object.
  nlohmann::json scene = nlohmann::json::parse(std::ifstream(source_dir() / "assets/scenes/two_objects.json"));
  scene["objects"][1].erase("class");
  const fs::path scene_file = fresh_temp_dir() / "classless.json";
  std::ofstream(scene_file) << scene.dump(2);
  const Result bad = run_cofusion("generate " + scene_file.string() + " --max-frames 1 --output " +
                                  (fresh_temp_dir() / "never").string());
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.output, HasSubstr("classless.json: objects[1].class: missing field: object 'can'"));
}

TEST(RunCommand, StaticSyntheticRoomTracksWithinFiveMillimetres) {
  const fs::path out = fresh_temp_dir();
  const int frames = 40;
  const Result r = run_cofusion("run --headless --validation --input synthetic:static_room --max-frames " +
                                std::to_string(frames) + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("device:"));
  expect_complete_output(out, frames);
  const synthetic::SyntheticSequence scene(synthetic::load_scene("static_room"), 0, frames);
  const double ate = camera_ate_m(scene.camera_trajectory(), out);
  RecordProperty("camera_ate_m", std::to_string(ate));
  EXPECT_LE(ate, 0.005);

  // The main job's own glTF files pass the Khronos validator (installed into the build tree).
  if (std::getenv("GLTF_VALIDATOR_DIR")) {
    const fs::path script = source_dir() / "tests/export/validate_gltf.mjs";
    const Result v = run_shell("node '" + script.string() + "' '" + (out / "models/model-0.glb").string() + "' '" +
                               (out / "scene.glb").string() + "'");
    EXPECT_EQ(v.exit_code, 0) << v.output;
  }
}

// The single-model issue's bound, 6 mm. The TUM folder applies the fr2 camera's listed depth
// correction (1.031); the pipeline measures 3.7 mm with it and 6.1 mm without (the recorded depth
// makes every tracker's trajectory 4% long). Runs have varied by up to 0.8 mm (GPU atomic order).
TEST(RunCommand, TumFr2DeskWithinSixMillimetresSlow) {
  const auto data = data_dir("tum_fr2_desk_50");
  if (!data) {
    GTEST_SKIP() << "TUM fr2/desk recording not found (set COFUSION_DATA)";
  }
  const fs::path out = fresh_temp_dir();
  const Result r = run_cofusion("run --headless --input tum:" + data->string() + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("depth / 1.031 (fr2 depth correction)"));
  expect_complete_output(out, 50);
  const double ate = camera_ate_m(read_tum_trajectory(*data / "groundtruth.txt"), out);
  RecordProperty("camera_ate_m", std::to_string(ate));
  EXPECT_LE(ate, 0.006);
}

// Issue "Semantic instance segmentation", done-when on a real desk: with the built-in detector in
// semantic mode, the desk's COCO objects become models named by their class (the monitor, in
// view from the first frame, among them), and the camera stays within 5 mm.
TEST(RunCommand, TumFr2DeskDetectorModelsDeskObjectsWithTheirClassesSlow) {
  const char* models = std::getenv("COFUSION_MODELS");
  if (!models || !fs::is_regular_file(fs::path(models) / "centernet.pb"))
    GTEST_SKIP() << "no converted models in $COFUSION_MODELS: run .ci/fetch-models.sh";
  const auto data = data_dir("tum_fr2_desk_50");
  if (!data) GTEST_SKIP() << "TUM fr2/desk recording not found (set COFUSION_DATA)";
  const fs::path out = fresh_temp_dir();
  const Result r = run_cofusion("run --headless --input tum:" + data->string() +
                                " --segmentation semantic --semantic-source detector --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto summary = read_json(out / "summary.json");
  expect_complete_output(out, 50, summary["models"].size());
  std::vector<std::string> classes;
  for (const auto& m : summary["models"]) {
    if (m["id"].get<int>() == 0) continue;
    classes.push_back(m["class"].get<std::string>());
    EXPECT_NE(classes.back(), "object") << "a model the detector made has no class: " << summary.dump(2);
    EXPECT_NE(classes.back(), "person") << summary.dump(2);
    EXPECT_GT(m["class_confidence"].get<double>(), 0.5) << summary.dump(2);
  }
  EXPECT_GE(classes.size(), 2u) << summary.dump(2);
  EXPECT_NE(std::find(classes.begin(), classes.end(), "tvmonitor"), classes.end()) << summary.dump(2);
  const double ate = camera_ate_m(read_tum_trajectory(*data / "groundtruth.txt"), out);
  RecordProperty("camera_ate_m", std::to_string(ate));
  EXPECT_LE(ate, 0.005);
}

// Issue "Real dynamic scenes" on the Bonn RGB-D Dynamic `crowd` recording (464 frames, people
// walking in front of a hand-held camera, detector masks), default settings: camera ATE <= 5 cm,
// no frame lost and at most 3 models spawned from people (the issue's bounds; measured 2.98 cm, 15
// frames refused (first 300 frames 2.51 cm), no model from a person: people the detector misses,
// entering at the image's edge, fail the rigidity check at spawn). With `--segmentation both`
// camera ATE <= 3 cm and no model for a person (the issue's bounds; measured 2.85 cm, first 300
// frames 2.53 cm, none; runs are deterministic, but the crowd frames tip a few millimetres either
// way at any change of tracking, so this margin is thin). Both rest on the keyframes' features:
// refused motions move halfway towards the pose they give (CameraCheckParams::keyframe_pose_gain),
// and every other frame by the share of the image the people cover (keyframe_pull_gain; 3.32 and
// 3.51 cm before it). The first 300 frames (the office, chairs and monitors as resting models, the
// first people walking through) stay within 3 cm in both modes.
struct BonnRun {
  double ate_m = 0;
  double first_300_ate_m = 0;  // of the first 300 frames alone (aligned on them)
  nlohmann::json summary;
  int nonrigid_drops = 0;  // models dropped as non-rigid movers (people)
};
constexpr const char* kNoBonn = "bonn_crowd_first_half (COFUSION_DATA) or the detector's models (COFUSION_MODELS) missing";
// Runs Bonn crowd with `options`, checks what every mode must give (exit 0, no frame lost, the
// first 300 frames within 3 cm) and records the camera's ATE; nullopt when the recording or the
// detector's models are missing.
std::optional<BonnRun> run_bonn(const std::string& options) {
  const char* models = std::getenv("COFUSION_MODELS");
  const auto data = data_dir("bonn_crowd_first_half");
  if (!data || !models || !fs::is_regular_file(fs::path(models) / "centernet.pb")) return std::nullopt;
  const fs::path out = fresh_temp_dir();
  const Result r = run_cofusion("run --headless --input tum:" + data->string() + " " + options + " --output " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  BonnRun b;
  b.summary = read_json(out / "summary.json");
  const Trajectory gt = read_tum_trajectory(*data / "groundtruth.txt");
  b.ate_m = camera_ate_m(gt, out);
  Trajectory first_300 = read_tum_trajectory(out / "trajectories" / "camera.txt");
  first_300.resize(std::min<size_t>(first_300.size(), 300));
  b.first_300_ate_m = eval::compute_ate(gt, first_300).translation_m.rmse;
  for (const auto& e : b.summary["events"]) b.nonrigid_drops += e.get<std::string>().find("(not rigid") != std::string::npos;
  std::printf("  camera ATE %.2f cm (first 300 frames %.2f cm), %zu refused frames\n", 100 * b.ate_m,
              100 * b.first_300_ate_m, b.summary["camera"]["refused_frames"].size());
  ::testing::Test::RecordProperty("camera_ate_m", std::to_string(b.ate_m));
  ::testing::Test::RecordProperty("first_300_ate_m", std::to_string(b.first_300_ate_m));
  EXPECT_EQ(b.summary["camera"]["lost_frames"].get<int>(), 0);
  EXPECT_LE(b.first_300_ate_m, 0.03);
  return b;
}

TEST(RunCommand, BonnCrowdCameraWithinFiveCentimetresSlow) {
  const auto b = run_bonn("");
  if (!b) GTEST_SKIP() << kNoBonn;
  EXPECT_LE(b->ate_m, 0.05);
  EXPECT_LE(b->nonrigid_drops, 3);
}

TEST(RunCommand, BonnCrowdBothModeCameraWithinThreeCentimetresSlow) {
  const auto b = run_bonn("--segmentation both");
  if (!b) GTEST_SKIP() << kNoBonn;
  EXPECT_LE(b->ate_m, 0.03);
  EXPECT_EQ(b->nonrigid_drops, 0);
}

// Issue "Real dynamic scenes", no ghosts: the generated walking_people (three people walk through
// the room for 120 frames; their masks exclude them) ends with the background model alone, the
// camera within 1 cm, and no person surfel left in the background: the background's surfels lie
// on the room's geometry (generated, geometry/background.glb) but for noise. Measured: 0.10 % of
// them more than 5 cm from it (0.31 % in a motion-only run, --semantic-source none), 0.02 % more
// than 10 cm (that bound does not tell the two runs apart; the 5 cm one does).
TEST(RunCommand, WalkingPeopleLeaveNoGhostsInTheBackgroundSlow) {
  const fs::path gt = fresh_temp_dir() / "walking_people", out = fresh_temp_dir();
  const Result g = run_cofusion("generate walking_people --output " + gt.string());
  ASSERT_EQ(g.exit_code, 0) << g.output;
  const Result r = run_cofusion("run --headless --input tum:" + gt.string() + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_complete_output(out, 120);
  const Trajectory camera_gt = read_tum_trajectory(gt / "groundtruth.txt");
  EXPECT_LE(camera_ate_m(camera_gt, out), 0.01);
  // The background model's frame is the first camera's.
  eval::ReconstructionParams params;
  params.outlier_thresholds_m = {0.05, 0.10};
  const auto recon = eval::evaluate_reconstruction_files(out / "models" / "model-0.ply", gt / "geometry" / "background.glb",
                                                         camera_gt.front().T_world_x, params);
  RecordProperty("share_over_5cm", std::to_string(recon.errors.share_above[0]));
  std::printf("  background surfels over 5 cm from the room: %.4f %%, over 10 cm: %.4f %%\n",
              100 * recon.errors.share_above[0], 100 * recon.errors.share_above[1]);
  // Between the measured 0.10 % and the 0.31 % a motion-only run leaves: ghosts of the people
  // would fail it.
  EXPECT_LE(recon.errors.share_above[0], 0.002);
  EXPECT_LE(recon.errors.share_above[1], 0.001);
}

// fr1's colour camera has a rolling shutter (its rows over 20 ms: tum_colour_readout_s), which the
// pipeline undoes for the camera's constant-velocity turn; without that, 2.5 cm.
TEST(RunCommand, TumFr1RpyFastRotationWithinTwoCentimetresSlow) {
  const auto data = data_dir("tum_fr1_rpy_200");
  if (!data) {
    GTEST_SKIP() << "TUM fr1/rpy recording not found (set COFUSION_DATA)";
  }
  const fs::path out = fresh_temp_dir();
  const Result r = run_cofusion("run --headless --input tum:" + data->string() + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_complete_output(out, 200);
  const double ate = camera_ate_m(read_tum_trajectory(*data / "groundtruth.txt"), out);
  RecordProperty("camera_ate_m", std::to_string(ate));
  EXPECT_LE(ate, 0.02);
  // A static scene: no model, also right after the fast turns (LifecycleParams::spawn_steady_frames).
  EXPECT_THAT(r.output, Not(HasSubstr("spawned model")));
}

// The multi-object outputs: a trajectory per object model beside camera.txt, per-model summary
// entries, label images with --save-segmentation.
TEST(RunCommand, MovingObjectsGetModelTrajectoriesSummaryAndLabelImagesSlow) {
  const fs::path out = fresh_temp_dir();
  const int frames = 30;
  const Result r = run_cofusion("run --headless --input synthetic:two_objects --save-segmentation --max-frames " +
                                std::to_string(frames) + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("spawned model"));
  const auto summary = read_json(out / "summary.json");
  ASSERT_GE(summary["models"].size(), 2u) << summary.dump(2);
  for (const auto& m : summary["models"]) {
    for (const char* key : {"id", "state", "surfels", "first_frame", "last_frame"}) EXPECT_TRUE(m.contains(key)) << key;
    const int id = m["id"].get<int>();
    EXPECT_TRUE(fs::exists(out / "models" / ("model-" + std::to_string(id) + ".glb"))) << id;
    if (id == 0) continue;
    const Trajectory t = read_tum_trajectory(out / "trajectories" / ("model-" + std::to_string(id) + ".txt"));
    EXPECT_GE(int(t.size()), m["last_frame"].get<int>() - m["first_frame"].get<int>() + 1) << id;
  }
  int label_images = 0;
  bool object_labelled = false;
  expect_classes_of_summary_models(out);
  for (const auto& entry : fs::directory_iterator(out / "segmentation")) {
    if (entry.path().extension() != ".png") continue;  // classes.txt
    ++label_images;
    const cv::Mat labels = cv::imread(entry.path().string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(labels.type(), CV_16UC1) << entry.path();
    for (int i = 0; i < labels.rows * labels.cols && !object_labelled; ++i) {
      const uint16_t v = labels.ptr<uint16_t>()[i];
      object_labelled = v != 0 && v != 0xFFFF;
    }
  }
  EXPECT_EQ(label_images, frames);
  EXPECT_TRUE(object_labelled);

  // The label images are named like the generated scene's masks, so `eval seg` scores them.
  const fs::path gt = fresh_temp_dir() / "gt";
  const Result g = run_cofusion("generate two_objects --max-frames " + std::to_string(frames) + " --output " + gt.string());
  ASSERT_EQ(g.exit_code, 0) << g.output;
  const Result e = run_cofusion("eval seg --json --gt-masks " + (gt / "masks").string() + " --est-masks " +
                                (out / "segmentation").string());
  ASSERT_EQ(e.exit_code, 0) << e.output;
  EXPECT_THAT(e.output, HasSubstr("\"frames_evaluated\": " + std::to_string(frames))) << e.output;
}

// The words of each line of `text`.
std::vector<std::vector<std::string>> words_per_line(const std::string& text) {
  std::vector<std::vector<std::string>> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    std::istringstream line_in(line);
    out.emplace_back();
    for (std::string w; line_in >> w;) out.back().push_back(w);
  }
  return out;
}

// The table a run ends with: a header, then one row of eight one-word cells per model of
// summary.json, naming files that exist.
void expect_model_table(const std::string& output, const fs::path& out) {
  const auto lines = words_per_line(output);
  const std::vector<std::string> header{"id", "class", "state", "surfels", "first", "last", "files", "trajectory"};
  const auto at = std::find(lines.begin(), lines.end(), header);
  EXPECT_NE(at, lines.end()) << output;
  if (at == lines.end()) return;
  const auto models = read_json(out / "summary.json")["models"];
  size_t row = static_cast<size_t>(at - lines.begin()) + 1;
  for (const auto& m : models) {
    EXPECT_LT(row, lines.size()) << output;
    if (row >= lines.size()) break;
    const auto& cells = lines[row++];
    EXPECT_EQ(cells.size(), header.size()) << output;
    if (cells.size() != header.size()) continue;
    const std::string id = std::to_string(m["id"].get<int>());
    EXPECT_EQ(cells[0], id);
    std::string class_name = m["class"].get<std::string>();
    std::replace(class_name.begin(), class_name.end(), ' ', '_');
    EXPECT_EQ(cells[1], class_name);
    EXPECT_EQ(cells[2], m["state"].get<std::string>());
    EXPECT_EQ(cells[3], std::to_string(m["surfels"].get<size_t>()));
    EXPECT_EQ(cells[4], std::to_string(m["first_frame"].get<int>()));
    EXPECT_EQ(cells[5], std::to_string(m["last_frame"].get<int>()));
    EXPECT_EQ(cells[6], "models/model-" + id + ".{glb,ply}");
    for (const char* ext : {".glb", ".ply"}) EXPECT_TRUE(fs::exists(out / "models" / ("model-" + id + ext))) << id;
    if (id == "0") {
      EXPECT_EQ(cells[7], "-") << "the background has no trajectory of its own";
    } else {
      EXPECT_EQ(cells[7], "trajectories/model-" + id + ".txt");
      EXPECT_TRUE(fs::exists(out / cells[7])) << cells[7];
    }
  }
  // Nothing after the rows looks like another one.
  if (row < lines.size()) {
    EXPECT_NE(lines[row].size(), header.size()) << output;
  }
}

// `cofusion run` ends with its model table and, on an input with ground truth, the camera's ATE:
// the value `eval` computes from the written trajectory, also in summary.json. table_placement's
// first 30 frames: the background and the box carried in (more models would only add rows).
TEST(RunCommand, EndsWithTheModelTableAndTheCameraAte) {
  const fs::path out = fresh_temp_dir();
  const int frames = 30;
  const Result r = run_cofusion("run --headless --input synthetic:table_placement --max-frames " +
                                std::to_string(frames) + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto summary = read_json(out / "summary.json");
  EXPECT_GE(summary["models"].size(), 2u) << summary["models"].dump();
  expect_model_table(r.output, out);

  const synthetic::SyntheticSequence scene(synthetic::load_scene("table_placement"), 0, frames);
  const double ate_m = camera_ate_m(scene.camera_trajectory(), out);
  EXPECT_NEAR(summary["camera"]["ate_rmse_m"].get<double>(), ate_m, 1e-6) << "trajectory files hold 1 um or better";
  const size_t line = r.output.find("camera ATE ");
  ASSERT_NE(line, std::string::npos) << r.output;
  double printed_cm = -1;
  int compared = 0;
  ASSERT_EQ(std::sscanf(r.output.c_str() + line, "camera ATE %lf cm RMSE over %d frames", &printed_cm, &compared), 2)
      << r.output.substr(line);
  EXPECT_NEAR(printed_cm, 100.0 * ate_m, 0.005 + 1e-4) << "printed to 0.01 cm";
  EXPECT_EQ(compared, frames);
  EXPECT_THAT(r.output.substr(line), HasSubstr("against the input's ground truth"));
}

// Without ground truth (a TUM folder without groundtruth.txt) the table is there and the ATE is not.
TEST(RunCommand, EndsWithoutAnAteWhenTheInputHasNoGroundTruth) {
  const fs::path tum = fresh_temp_dir() / "tum";
  const Result g = run_cofusion("generate static_room --max-frames 3 --output " + tum.string());
  ASSERT_EQ(g.exit_code, 0) << g.output;
  ASSERT_TRUE(fs::remove(tum / "groundtruth.txt"));
  const fs::path out = fresh_temp_dir();
  const Result r = run_cofusion("run --headless --input tum:" + tum.string() + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_model_table(r.output, out);
  EXPECT_THAT(r.output, Not(HasSubstr("ATE"))) << r.output;
  EXPECT_FALSE(read_json(out / "summary.json")["camera"].contains("ate_rmse_m"));
}

TEST(RunCommand, MissingInputFailsWithOneLineReasonAndNoOutput) {
  const fs::path out = fresh_temp_dir() / "never";
  const Result r = run_cofusion("run --headless --input tum:/no/such/folder --output " + out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("/no/such/folder"));
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

TEST(RunCommand, DepthCorrectionOutOfRangeOrOnSyntheticFails) {
  const fs::path out = fresh_temp_dir() / "never";
  Result r = run_cofusion("run --headless --depth-correction 3 --output " + out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("--depth-correction"));
  r = run_cofusion("run --headless --depth-correction 1.03 --max-frames 2 --output " + out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("does not apply to synthetic scenes"));
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

TEST(RunCommand, UnwritableOutputFailsBeforeProcessing) {
  const fs::path dir = fresh_temp_dir();
  std::ofstream(dir / "a-file") << "x";
  const Result r = run_cofusion("run --headless --max-frames 2 --output " + (dir / "a-file" / "out").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("a-file"));
}

// `cofusion run` with `config` (JSON) written to DIR/NAME; `run_options` before --config.
Result run_with_config(const fs::path& dir, const std::string& name, const std::string& config,
                       const std::string& run_options = "") {
  std::ofstream(dir / name) << config;
  return run_cofusion("run --headless " + run_options + "--config " + (dir / name).string() + " --output " +
                      (dir / "out").string());
}

// A run with `config` fails, and its output says `message`.
void expect_config_rejected(const fs::path& dir, const std::string& config, const std::string& message) {
  const Result r = run_with_config(dir, "config.json", config);
  EXPECT_NE(r.exit_code, 0) << config;
  EXPECT_THAT(r.output, HasSubstr(message)) << config << "\n" << r.output;
}

TEST(RunCommand, BadConfigNamesFileAndKey) {
  const fs::path dir = fresh_temp_dir();
  const Result r = run_with_config(dir, "config.json", R"({"tracker": {"photometric_wieght": 2}})");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("photometric_wieght"));
  EXPECT_THAT(r.output, HasSubstr("config.json"));
}

// Found by fuzz_config: a number beyond double's range is JSON that nlohmann rejects with
// out_of_range, not parse_error, and it escaped the reader without naming the file.
TEST(RunCommand, ConfigNumberBeyondDoubleNamesTheFile) {
  const fs::path dir = fresh_temp_dir();
  const Result r = run_with_config(dir, "config.json", R"({"tracker": {"photometric_weight": 1E3333}})");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("config.json is not valid JSON")) << r.output;
  EXPECT_THAT(r.output, HasSubstr("number overflow")) << r.output;
}

TEST(RunCommand, SemanticConfigGroupIsReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  const Result r = run_with_config(dir, "config.json", R"({"semantic": {"join_min_iou": 1.5}})");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("config.json: semantic: confirm_frames must be >= 1")) << r.output;
  const Result ok = run_with_config(dir, "ok.json", R"({"semantic": {"confirm_frames": 3, "join_min_iou": 0.5}})",
                                    "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

TEST(RunCommand, SpawnRigidityConfigIsReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  const Result r = run_with_config(dir, "config.json", R"({"lifecycle": {"spawn_rigidity": {"min_aligned_fraction": 1.5}}})");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("lifecycle.spawn_rigidity")) << r.output;
  const Result typo = run_with_config(dir, "typo.json", R"({"lifecycle": {"spawn_rigidity": {"min_alinged_fraction": 0.5}}})");
  EXPECT_NE(typo.exit_code, 0);
  EXPECT_THAT(typo.output, HasSubstr("min_alinged_fraction")) << typo.output;
  const Result ok = run_with_config(dir, "ok.json", R"({"lifecycle": {"spawn_rigidity": {"enabled": false, "association_m": 0.05}}})",
                                    "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

TEST(RunCommand, ProbationObservedConfigIsReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  const Result r = run_with_config(dir, "config.json", R"({"lifecycle": {"probation_observed": {"max_still_ratio": 1.5}}})");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("lifecycle.probation_observed")) << r.output;
  const Result typo = run_with_config(dir, "typo.json", R"({"lifecycle": {"probation_observed": {"point": 100}}})");
  EXPECT_NE(typo.exit_code, 0);
  EXPECT_THAT(typo.output, HasSubstr("point")) << typo.output;
  const Result ok = run_with_config(dir, "ok.json", R"({"lifecycle": {"probation_observed": {"points": 0}}})",
                                    "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

TEST(RunCommand, KeyframeGainConfigsAreReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  for (const std::string key : {"keyframe_pose_gain", "keyframe_pull_gain"}) {
    const Result r = run_with_config(dir, "config.json", R"({"camera_check": {")" + key + R"(": 1.5}})");
    EXPECT_NE(r.exit_code, 0) << key;
    EXPECT_THAT(r.output, HasSubstr(key)) << r.output;
    EXPECT_THAT(r.output, HasSubstr("in [0, 1]")) << r.output;
    const Result ok = run_with_config(dir, "ok.json", R"({"camera_check": {")" + key + R"(": 0}})", "--max-frames 3 ");
    EXPECT_EQ(ok.exit_code, 0) << ok.output;
  }
  const Result r = run_with_config(dir, "config.json", R"({"camera_check": {"keyframe_pull_min_inliers": -1}})");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("keyframe_pull_min_inliers >= 0")) << r.output;
}

TEST(RunCommand, RetrackConfigIsReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  for (const std::string bad : {R"("min_taken_fraction": 1.5)", R"("min_region_fraction": -0.1)", R"("surge_factor": -1)",
                                R"("baseline_frames": -2)", R"("max_correction_m": -0.01)", R"("max_correction_deg": -1)"})
    expect_config_rejected(dir, R"({"retrack": {)" + bad + "}}",
                           "retrack: min_taken_fraction and min_region_fraction must be in [0, 1]");
  const Result ok = run_with_config(dir, "ok.json", R"({"retrack": {"min_taken_fraction": 0.01, "baseline_frames": 4}})",
                                    "--max-frames 3 ");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  // The static scene's first frames take nothing from the camera: the list is there, empty.
  EXPECT_EQ(read_json(dir / "out" / "summary.json")["camera"]["retracked_frames"], nlohmann::json::array());
}

TEST(RunCommand, RollingShutterConfigIsReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  for (const std::string bad : {R"("colour_readout_s": 2)", R"("nominal_frame_interval_s": 0)"}) {
    const Result r = run_with_config(dir, "config.json", R"({"rolling_shutter": {)" + bad + "}}");
    EXPECT_NE(r.exit_code, 0) << bad;
    EXPECT_THAT(r.output, HasSubstr("rolling_shutter: colour_readout_s must be within -1..1 s")) << r.output;
  }
  const Result ok = run_with_config(dir, "ok.json", R"({"rolling_shutter": {"colour_readout_s": -0.02}})", "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

TEST(RunCommand, ObjectPhotometricSettingsAreReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  expect_config_rejected(dir, R"({"lifecycle": {"object_photometric_weight": -0.1}})", "object_photometric_weight: must be >= 0");
  expect_config_rejected(dir, R"({"lifecycle": {"object_icp_noise_reference_depth_m": -1}})",
                         "object_icp_noise_reference_depth_m: must be >= 0");
  expect_config_rejected(dir, R"({"lifecycle": {"object_max_intensity_diff": 0}})", "object_max_intensity_diff: must be > 0");
  expect_config_rejected(dir, R"({"lifecycle": {"object_photometric_huber_k": -1}})", "object_photometric_huber_k: must be >= 0");
  expect_config_rejected(dir, R"({"lifecycle": {"object_outline_huber_scale": -1}})", "object_outline_huber_scale: must be >= 0");
  const Result ok = run_with_config(dir, "ok.json",
                                    R"({"lifecycle": {"object_photometric_weight": 1, "object_max_intensity_diff": 0.5, "object_photometric_huber_k": 3,
                                                     "object_outline_huber_scale": 3}})",
                                    "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

// SemanticParams::track_woken: read (a wrong type names the key), and a run with it off works.
TEST(RunCommand, TrackWokenSettingIsRead) {
  const fs::path dir = fresh_temp_dir();
  expect_config_rejected(dir, R"({"semantic": {"track_woken": 3}})", "track_woken");
  const Result ok = run_with_config(dir, "ok.json", R"({"semantic": {"track_woken": false}})", "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

// LifecycleParams::border_unpaired_cost and border_still_min_gain (the second start of objects cut
// by the image's border): read and checked.
TEST(RunCommand, BorderSecondStartSettingsAreReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  expect_config_rejected(dir, R"({"lifecycle": {"border_unpaired_cost": -1}})", "border_unpaired_cost: must be >= 0");
  for (const std::string bad : {"-0.1", "1"})
    expect_config_rejected(dir, R"({"lifecycle": {"border_still_min_gain": )" + bad + "}}",
                           "border_still_min_gain: must be in [0, 1)");
  const Result ok = run_with_config(dir, "ok.json", R"({"lifecycle": {"border_unpaired_cost": 0, "border_still_min_gain": 0.1}})",
                                    "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

// The photometric reweighting options (TrackerParams::photometric_gradient_c, photometric_cauchy_k):
// read, checked, and a run with both on (the reweighted reduction kernel) completes.
TEST(RunCommand, PhotometricReweightingConfigsAreReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  for (const std::string key : {"photometric_gradient_c", "photometric_cauchy_k"}) {
    const Result r = run_with_config(dir, "config.json", R"({"tracker": {")" + key + R"(": -1}})");
    EXPECT_NE(r.exit_code, 0) << key;
    EXPECT_THAT(r.output, HasSubstr(key + " must be >= 0")) << r.output;
  }
  const Result ok = run_with_config(dir, "ok.json", R"({"tracker": {"photometric_gradient_c": 0.05, "photometric_cauchy_k": 2.385}})",
                                    "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

// The cap on a tile's share of the camera's colour term (CameraCheckParams::photometric_tile_cap):
// read, checked, and a run with it and the gradient weights (both in the reweighted kernel)
// completes.
TEST(RunCommand, PhotometricTileCapIsReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  const Result r = run_with_config(dir, "config.json", R"({"camera_check": {"photometric_tile_cap": -1}})");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("photometric_tile_cap >= 0")) << r.output;
  const Result ok = run_with_config(
      dir, "ok.json", R"({"camera_check": {"photometric_tile_cap": 8}, "tracker": {"photometric_gradient_c": 0.05}})",
      "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

TEST(RunCommand, MergeWindowStepIsReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  const Result bad = run_with_config(dir, "config.json", R"({"fusion": {"merge_window_step_cells": 0}})");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.output, HasSubstr("merge_window_step_cells: must be 1..8")) << bad.output;
  const Result ok = run_with_config(dir, "ok.json", R"({"fusion": {"merge_window_step_cells": 1}})", "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

TEST(RunCommand, SpawnEvidenceSettingsAreReadAndChecked) {
  const fs::path dir = fresh_temp_dir();
  expect_config_rejected(dir, R"({"lifecycle": {"rising_min_area_fraction": 1.5}})", "rising_min_area_fraction in [0, 1)");
  expect_config_rejected(dir, R"({"lifecycle": {"rising_min_step_m": -0.001}})", "rising_*: costs must be >= 0");
  expect_config_rejected(dir, R"({"lifecycle": {"slide_min_fraction": 2}})", "slide_min_fraction at most 1");
  expect_config_rejected(dir, R"({"lifecycle": {"spawn_keep_area_fraction": 0.05}})",
                         "spawn_keep_area_fraction: must be in [0, spawn_min_area_fraction]");
  expect_config_rejected(dir, R"({"lifecycle": {"spawn_persist_min_area_fraction": 1.5}})",
                         "spawn_persist_min_area_fraction: must be in [0, 1)");
  expect_config_rejected(dir, R"({"lifecycle": {"spawn_persist_mover_clearance_px": -1}})",
                         "spawn_persist_mover_clearance_px: must be >= 0");
  expect_config_rejected(dir, R"({"costs": {"background_takes_unmodelled": "yes"}})", "background_takes_unmodelled");
  expect_config_rejected(dir, R"({"lifecycle": {"hold_spawn_candidates": 1}})", "hold_spawn_candidates");
  const Result ok = run_with_config(dir, "ok.json", R"({"lifecycle": {"rising_min_step_m": 0, "slide_min_shift_px": 0, "spawn_keep_area_fraction": 0,
                                                                      "hold_spawn_candidates": false},
                                                        "costs": {"background_takes_unmodelled": false}})",
                                    "--max-frames 3 ");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

// --screenshot offscreen (headless) and from the window under a virtual X server: a PNG of the
// final view, showing the model (not just the background colour).
void expect_screenshot(const fs::path& png) {
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty()) << png;
  cv::Mat grey;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  cv::Scalar mean, stddev;
  cv::meanStdDev(grey, mean, stddev);
  EXPECT_GT(stddev[0], 20.0) << "screenshot looks empty";
}

TEST(RunCommand, HeadlessScreenshotShowsTheModel) {
  const fs::path out = fresh_temp_dir();
  const Result r = run_cofusion("run --headless --max-frames 5 --output " + out.string() + " --screenshot " +
                                (out / "view.png").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_screenshot(out / "view.png");
}

TEST(RunCommand, ViewerWindowRunsUnderXvfbAndTakesAScreenshot) {
  if (std::system("command -v xvfb-run > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "xvfb-run not installed (Debian: xvfb)";
  }
  const fs::path out = fresh_temp_dir();
  const Result r = run_shell("xvfb-run -a " + cofusion_exe().string() + " run --max-frames 5 --output " + out.string() +
                             " --screenshot " + (out / "view.png").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_screenshot(out / "view.png");
}

TEST(BenchCommand, KernelProfileListsEveryStreamGroupsKernels) {
  const Result r = run_cofusion(
      "bench --no-kernels --no-pipeline --no-semantic --models-input synthetic:two_objects --frames 5 --kernel-profile");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("GPU time per kernel (timestamp queries), per frame over 3 frames"));
  for (const char* row : {"frame: bilateral_depth ", "background: splat_surfels for prediction ",
                          "background: splat_surfels for fusion ", "background: fuse_associate ",
                          "background: icp_rgb_reduce 640x480 ", "background: icp_rgb_reduce 80x60 ", "all kernels "})
    EXPECT_THAT(r.output, HasSubstr(row)) << r.output;
}

// fps per segmentation mode: motion alone, then semantic and both with the scene's own masks
// and (where the converted models are) with the detector, which reports its time and how often it ran.
TEST(BenchCommand, SemanticFiguresPerModeAndMaskSource) {
  const Result r = run_cofusion("bench --no-kernels --no-pipeline --no-models --semantic-input synthetic:walking_people --frames 6");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("segmentation modes on synthetic:walking_people (6 frames")) << r.output;
  for (const char* row : {"motion    none ", "motion    masks ", "semantic  masks ", "both      masks "})
    EXPECT_THAT(r.output, HasSubstr(row)) << r.output;
  const char* models = std::getenv("COFUSION_MODELS");
  if (models && fs::is_regular_file(fs::path(models) / "centernet.pb")) {
    EXPECT_THAT(r.output, HasSubstr("motion    detector ")) << r.output;
    EXPECT_THAT(r.output, HasSubstr("both      detector ")) << r.output;
    EXPECT_THAT(r.output, HasSubstr("both      detector 1/4 ")) << r.output;
    EXPECT_THAT(r.output, HasSubstr("ran on 2 of 6 frames")) << r.output;  // frames 0 and 4
    EXPECT_THAT(r.output, HasSubstr("ms per run, ran on ")) << r.output;
  }
}

// Each figure's ratio is its milliseconds over the OpenCV odometry figure of the frames it was
// measured on (rows of stages carry it as `ratio`).
void expect_ratios_of(const nlohmann::json& stages, double opencv_ms) {
  ASSERT_FALSE(stages.empty());
  for (const auto& row : stages) {
    const double ms = row["median_ms"].get<double>();
    EXPECT_GT(ms, 0.0) << row.dump();
    EXPECT_NEAR(row["ratio"].get<double>(), ms / opencv_ms, 1e-9 * ms / opencv_ms) << row.dump();
  }
}

double opencv_ms_of(const nlohmann::json& group, int frames) {
  EXPECT_EQ(group["opencv_odometry"]["frames"].get<int>(), frames - 1) << group.dump();  // all but the first
  const double ms = group["opencv_odometry"]["median_ms"].get<double>();
  EXPECT_GT(ms, 0.0);
  return ms;
}

// Every figure goes to --json, each pipeline figure also as a ratio to OpenCV's frame-to-frame
// odometry timed on the same frames in the same run; the terminal shows the ratios too.
TEST(BenchCommand, JsonHasEveryFigureAndItsRatioToOpenCvOdometry) {
  const fs::path json_path = fresh_temp_dir() / "bench.json";
  const Result r = run_cofusion("bench --iterations 2 --warmup 1 --frames 5 --models-input synthetic:two_objects "
                                "--semantic-input synthetic:walking_people --json " + json_path.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("x OpenCV odometry"));
  EXPECT_THAT(r.output, HasSubstr("OpenCV RgbdICPOdometry (OpenCV 4."));
  const auto j = read_json(json_path);
  EXPECT_THAT(j["ratio"].get<std::string>(), HasSubstr("RgbdICPOdometry"));
  EXPECT_FALSE(j["device"].get<std::string>().empty());

  // Kernels on the built-in frame: milliseconds only (no input to run OpenCV on).
  std::vector<std::string> kernel_stages;
  for (const auto& row : j["kernels"]["stages"]) {
    kernel_stages.push_back(row["stage"].get<std::string>());
    EXPECT_FALSE(row.contains("ratio"));
  }
  EXPECT_THAT(kernel_stages, ::testing::Contains("preprocess whole frame 640x480"));
  EXPECT_GT(j["kernels"]["preprocessing_fps"].get<double>(), 0.0);

  ASSERT_EQ(j["pipeline"].size(), 2u);
  for (const auto& [pipeline, width] : {std::pair{j["pipeline"][0], 640}, std::pair{j["pipeline"][1], 320}}) {
    EXPECT_EQ(pipeline["width"].get<int>(), width);
    EXPECT_EQ(pipeline["input"], "synthetic:static_room");
    const double opencv_ms = opencv_ms_of(pipeline, 5);
    expect_ratios_of(pipeline["stages"], opencv_ms);
    const auto& whole = pipeline["whole_frame"];
    const double median_ms = whole["median_ms"].get<double>();
    EXPECT_NEAR(whole["ratio"].get<double>(), median_ms / opencv_ms, 1e-9 * median_ms / opencv_ms);
    EXPECT_NEAR(whole["fps_median_frame"].get<double>(), 1000.0 / median_ms, 1e-9 * 1000.0 / median_ms);
    std::vector<std::string> stages;
    for (const auto& row : pipeline["stages"]) stages.push_back(row["stage"].get<std::string>());
    EXPECT_THAT(stages, ::testing::IsSupersetOf({"preprocess", "track", "fuse", "whole frame"}));
  }

  // Frames grouped by the number of active models: every counted frame in one group.
  ASSERT_EQ(j["models"].size(), 1u);
  const auto& models = j["models"][0];
  EXPECT_EQ(models["input"], "synthetic:two_objects");
  const double models_opencv_ms = opencv_ms_of(models, 5);
  int grouped = 0, previous_count = 0;
  for (const auto& group : models["by_active_models"]) {
    EXPECT_GT(group["active_models"].get<int>(), previous_count);  // one group per count, ascending
    previous_count = group["active_models"].get<int>();
    grouped += group["frames"].get<int>();
    const double median_ms = group["median_ms"].get<double>();
    EXPECT_NEAR(group["ratio"].get<double>(), median_ms / models_opencv_ms, 1e-9 * median_ms / models_opencv_ms);
    expect_ratios_of(group["stages"], models_opencv_ms);
  }
  EXPECT_EQ(grouped, 5 - 2);
  // First and last counted frames: 3 counted frames, one at each end.
  const auto& first_last = models["first_last"];
  EXPECT_EQ(first_last["window_frames"].get<int>(), 1);
  const double first_ms = first_last["first_median_ms"].get<double>(), last_ms = first_last["last_median_ms"].get<double>();
  EXPECT_GT(first_ms, 0.0);
  EXPECT_NEAR(first_last["change"].get<double>(), last_ms / first_ms - 1, 1e-9);

  // Per segmentation mode: the mean frame over OpenCV's median.
  const auto& semantic = j["semantic"];
  EXPECT_EQ(semantic["input"], "synthetic:walking_people");
  const double semantic_opencv_ms = opencv_ms_of(semantic, 5);
  std::vector<std::string> modes;
  for (const auto& mode : semantic["modes"]) {
    modes.push_back(mode["segmentation"].get<std::string>() + " " + mode["masks"].get<std::string>());
    const double mean_ms = mode["mean_ms"].get<double>();
    EXPECT_NEAR(mode["ratio"].get<double>(), mean_ms / semantic_opencv_ms, 1e-9 * mean_ms / semantic_opencv_ms);
    EXPECT_NEAR(mode["fps_mean_frame"].get<double>(), 1000.0 / mean_ms, 1e-9 * 1000.0 / mean_ms);
  }
  EXPECT_THAT(modes, ::testing::IsSupersetOf({"motion none", "semantic masks", "both masks"}));
}

// A --json path that cannot be written fails at once, naming it, before any figure is measured.
TEST(BenchCommand, UnwritableJsonPathFailsBeforeMeasuring) {
  const fs::path dir = fresh_temp_dir();
  std::ofstream(dir / "a-file") << "not a folder";
  const Result r = run_cofusion("bench --json " + (dir / "a-file" / "bench.json").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("a-file"));
  EXPECT_THAT(r.output, ::testing::Not(HasSubstr("device:")));
}

TEST(RunCommand, EverySubcommandHasHelp) {
  for (const char* sub : {"run", "bench", "eval", "generate", "convert"}) {
    const Result r = run_cofusion(std::string(sub) + " --help");
    EXPECT_EQ(r.exit_code, 0) << sub;
    EXPECT_THAT(r.output, HasSubstr("--")) << sub;
  }
  EXPECT_NE(run_cofusion("no-such-command").exit_code, 0);
}

}  // namespace
}  // namespace cofusion::test
