// Scene descriptions: the shipped scenes parse, bad scenes fail with the file and field named, and
// poses over time follow the documented interpolation.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "common/error.h"
#include "support/test_support.h"
#include "synthetic/motion.h"
#include "synthetic/scene.h"
#include "synthetic/synthetic_source.h"

namespace cofusion::synthetic {
namespace {

using json = nlohmann::json;

// A small valid scene; tests break one field of it at a time.
json minimal_scene() {
  return json::parse(R"({
    "frames": 10,
    "camera": {"keyframes": [{"frame": 0, "position": [0, 0, 1], "look_at": [1, 0, 1]}]},
    "room": {"size": [4, 4, 3]},
    "objects": [{"name": "cube", "class": "box", "shape": "box", "size": [0.1, 0.1, 0.1],
                 "texture": {"type": "checker", "colors": [[255, 0, 0], [0, 0, 255]]},
                 "keyframes": [{"frame": 0, "position": [1, 0, 1]}, {"frame": 9, "position": [1, 0.2, 1]}]}]
  })");
}

using test::error_of;

// Writes `j` to a .json file and loads it by path; returns the error message.
std::string load_error(const json& j, const std::string& file_name = "bad_scene.json") {
  const auto path = test::fresh_temp_dir() / file_name;
  std::ofstream(path) << j.dump(2);
  return error_of([&] { load_scene(path.string()); });
}

TEST(SyntheticScene, ShippedScenesParse) {
  const auto names = builtin_scene_names();
  for (const char* required : {"static_room", "one_object", "table_placement", "handover", "walking_people", "camera_loss"})
    EXPECT_NE(std::find(names.begin(), names.end(), required), names.end()) << required;
  EXPECT_NE(std::find(names.begin(), names.end(), std::string(kDefaultScene)), names.end());
  for (const auto& name : names) {
    SCOPED_TRACE(name);
    const SceneDescription s = load_scene(name);
    EXPECT_EQ(s.name, name);
    EXPECT_GE(s.frames, 45);  // the multi-object test and benchmark scenes are short (45 and 50 frames)
    EXPECT_LE(s.frames, 150);
    EXPECT_DOUBLE_EQ(s.fps, 30);
    EXPECT_EQ(s.camera.intrinsics.width, 640);
    EXPECT_EQ(s.camera.intrinsics.height, 480);
    EXPECT_DOUBLE_EQ(s.camera.intrinsics.fx, 525);
    EXPECT_DOUBLE_EQ(s.camera.intrinsics.cy, 239.5);
    EXPECT_TRUE(s.room.has_value());
    EXPECT_TRUE(s.table.has_value());
    EXPECT_FALSE(s.description.empty());
  }
  EXPECT_EQ(load_scene("").name, std::string(kDefaultScene));
}

TEST(SyntheticScene, LoadsFromAFilePath) {
  const auto path = test::fresh_temp_dir() / "my_scene.json";
  std::ofstream(path) << minimal_scene().dump();
  const SceneDescription s = load_scene(path.string());
  EXPECT_EQ(s.name, "my_scene");
  EXPECT_EQ(s.frames, 10);
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].name, "cube");
  EXPECT_EQ(s.objects[0].class_name, "box");
  EXPECT_EQ(s.objects[0].texture.type, TextureType::kChecker);
  EXPECT_FLOAT_EQ(s.objects[0].texture.colors[1].z(), 255.0f);
}

TEST(SyntheticScene, UnknownSceneNamesTheBuiltins) {
  const std::string msg = error_of([] { load_scene("no_such_scene"); });
  EXPECT_NE(msg.find("no_such_scene"), std::string::npos) << msg;
  EXPECT_NE(msg.find("static_room"), std::string::npos) << msg;
}

TEST(SyntheticScene, ErrorsNameTheFileAndField) {
  struct Case {
    std::function<void(json&)> mutate;
    std::string expected;  // the field path and the problem
  };
  const std::vector<Case> cases = {
      {[](json& j) { j.erase("frames"); }, "frames: missing field"},
      {[](json& j) { j["frames"] = "ten"; }, "frames: expected an integer"},
      {[](json& j) { j["frames"] = 0; }, "frames: must be in"},
      {[](json& j) { j["objects"][0]["keyframes"][1]["position"] = "up"; },
       "objects[0].keyframes[1].position: expected an array of 3 numbers"},
      {[](json& j) { j["objects"][0]["keyframes"][1]["position"] = json::array({1, 2}); },
       "objects[0].keyframes[1].position: expected an array of 3 numbers"},
      {[](json& j) { j["objects"][0]["texture"]["colour"] = json::array({1, 2, 3}); },
       "objects[0].texture.colour: unknown field"},
      {[](json& j) { j["objects"][0]["texture"]["type"] = "plaid"; }, "objects[0].texture.type: unknown texture type"},
      {[](json& j) { j["objects"][0]["shape"] = "torus"; }, "objects[0].shape: unknown shape"},
      {[](json& j) { j["objects"][0].erase("size"); }, "objects[0].size: missing field"},
      {[](json& j) { j["objects"][0]["size"] = json::array({0.1, -1, 0.1}); }, "objects[0].size: extents must be > 0"},
      {[](json& j) { j["objects"][0]["keyframes"][1]["frame"] = 0; },
       "objects[0].keyframes[1]: keyframes must be in strictly increasing time"},
      {[](json& j) { j["objects"][0]["keyframes"][0]["look_at"] = json::array({0, 0, 0}); },
       "objects[0].keyframes[0].look_at: only camera keyframes may use look_at"},
      {[](json& j) { j["camera"]["keyframes"][0]["look_at"] = json::array({0, 0, 1}); },
       "camera.keyframes[0].look_at: look_at target equals the camera position"},
      {[](json& j) { j["camera"].erase("keyframes"); }, "camera.keyframes: missing field"},
      {[](json& j) { j["camera"]["intrinsics"] = {{"fx", -5}}; }, "camera.intrinsics.fx: must be > 0"},
      {[](json& j) { j["noise"] = "loud"; }, "noise: expected true, false or an object"},
      {[](json& j) { j["noise"] = {{"edge_drop_probability", 2}}; }, "noise.edge_drop_probability: must be in [0, 1]"},
      {[](json& j) { j["objects"][0]["present_frames"] = json::array({5, 2}); }, "objects[0].present_frames"},
      {[](json& j) { j["objects"][0].erase("class"); }, "objects[0].class: missing field: object 'cube' needs a class"},
      {[](json& j) { j["objects"][0]["class"] = "teddy bear"; }, "objects[0].class: object 'cube': class 'teddy bear'"},
      {[](json& j) { j["objects"][0]["class"] = 3; }, "objects[0].class: expected a string"},
      {[](json& j) { j["room"]["size"] = json::array({4, 4}); }, "room.size: expected an array of 3 numbers"},
      {[](json& j) { j["tabel"] = json::object(); }, "tabel: unknown field"},
  };
  for (const auto& c : cases) {
    json j = minimal_scene();
    c.mutate(j);
    const std::string msg = load_error(j);
    EXPECT_NE(msg.find("bad_scene.json"), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.expected), std::string::npos) << "expected '" << c.expected << "' in: " << msg;
  }
}

TEST(SyntheticScene, InvalidJsonNamesTheFile) {
  const auto path = test::fresh_temp_dir() / "broken.json";
  std::ofstream(path) << "{ \"frames\": 10, ";
  const std::string msg = error_of([&] { load_scene(path.string()); });
  EXPECT_NE(msg.find("broken.json"), std::string::npos) << msg;
  EXPECT_NE(msg.find("invalid JSON"), std::string::npos) << msg;
}

// Found by fuzz_scene: nlohmann rejects a number beyond double's range with out_of_range, which
// escaped the parser without naming the scene.
TEST(SyntheticScene, NumberBeyondDoubleIsInvalidJsonNamingTheScene) {
  const std::string msg = error_of([] { parse_scene(R"({"frames": 50e700})", "huge.json"); });
  EXPECT_NE(msg.find("huge.json: invalid JSON"), std::string::npos) << msg;
}

TEST(SyntheticScene, ParsesRotationsAndQuaternions) {
  json j = minimal_scene();
  j["objects"][0]["keyframes"][0]["rotation"] = {{"axis", {0, 0, 2}}, {"angle_deg", 90}};
  j["objects"][0]["keyframes"][1]["quaternion"] = {0, 0, std::sin(std::numbers::pi / 4), std::cos(std::numbers::pi / 4)};
  const SceneDescription s = parse_scene(j.dump(), "inline");
  const Eigen::Matrix3d R0 = s.objects[0].path.keyframes[0].pose.linear();
  const Eigen::Matrix3d R1 = s.objects[0].path.keyframes[1].pose.linear();
  EXPECT_TRUE((R0 * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  EXPECT_TRUE(R0.isApprox(R1, 1e-12));
  EXPECT_DOUBLE_EQ(s.objects[0].path.keyframes[1].t_s, 9.0 / 30.0);
}

TEST(SyntheticMotion, LinearTranslationAndSlerpRotation) {
  KeyframedPath path;
  Pose a = Pose::Identity(), b = Pose::Identity();
  a.translation() = Eigen::Vector3d(0, 0, 1);
  b.translation() = Eigen::Vector3d(2, 0, 1);
  b.linear() = Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  path.keyframes = {{1.0, a}, {3.0, b}};

  const Pose mid = interpolate(path, 2.0);
  EXPECT_TRUE(mid.translation().isApprox(Eigen::Vector3d(1, 0, 1), 1e-12));
  const Eigen::AngleAxisd aa(mid.linear());
  EXPECT_NEAR(aa.angle(), std::numbers::pi / 4, 1e-12);
  EXPECT_NEAR(std::abs(aa.axis().z()), 1.0, 1e-12);
  const Pose quarter = interpolate(path, 1.5);
  EXPECT_NEAR(quarter.translation().x(), 0.5, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(quarter.linear()).angle(), std::numbers::pi / 8, 1e-12);
  // Held before the first and after the last keyframe.
  EXPECT_TRUE(interpolate(path, 0.0).isApprox(a));
  EXPECT_TRUE(interpolate(path, 10.0).isApprox(b));

  path.interpolation = Interpolation::kSmooth;  // smoothstep: same midpoint, slower near the keys
  EXPECT_TRUE(interpolate(path, 2.0).translation().isApprox(Eigen::Vector3d(1, 0, 1), 1e-12));
  EXPECT_NEAR(interpolate(path, 1.5).translation().x(), 2 * 0.15625, 1e-12);
}

TEST(SyntheticMotion, LookAtPointsTheCameraAtTheTarget) {
  const Eigen::Vector3d eye(1, 2, 1.5), target(0, 0, 0.8);
  const Eigen::Matrix3d R = look_at_rotation(eye, target, Eigen::Vector3d::UnitZ());
  EXPECT_TRUE((R.transpose() * R).isIdentity(1e-12));
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE(R.col(2).isApprox((target - eye).normalized(), 1e-12));  // camera z forward
  EXPECT_NEAR(R.col(0).z(), 0.0, 1e-12);                              // no roll
  EXPECT_LT(R.col(1).z(), 0.0);                                        // camera y points down
}

TEST(SyntheticMotion, JitterIsSmoothDeterministicAndOfTheGivenSize) {
  JitterDesc j;
  j.translation_m = 0.004;
  j.rotation_deg = 0.5;
  EXPECT_TRUE(camera_jitter(JitterDesc{}, 1, 0.7).isApprox(Pose::Identity()));
  EXPECT_TRUE(camera_jitter(j, 5, 0.7).isApprox(camera_jitter(j, 5, 0.7)));
  EXPECT_FALSE(camera_jitter(j, 5, 0.7).isApprox(camera_jitter(j, 6, 0.7), 1e-6));
  double sum_sq = 0, max_step = 0;
  const int n = 6000;
  Eigen::Vector3d prev = camera_jitter(j, 5, 0).translation();
  for (int i = 1; i <= n; ++i) {
    const Eigen::Vector3d t = camera_jitter(j, 5, i / 30.0).translation();
    sum_sq += t.squaredNorm() / 3;
    max_step = std::max(max_step, (t - prev).norm());
    prev = t;
  }
  EXPECT_NEAR(std::sqrt(sum_sq / n), j.translation_m, 0.35 * j.translation_m);
  EXPECT_LT(max_step, 0.006);  // smooth: millimetres per frame, not a jump
}

TEST(SyntheticSequence, ObjectsAreAbsentOutsideTheirFrames) {
  json j = minimal_scene();
  j["objects"][0]["present_frames"] = {3, 6};
  SyntheticSequence seq(parse_scene(j.dump(), "inline"));
  EXPECT_FALSE(seq.T_world_object(1, 2).has_value());
  EXPECT_TRUE(seq.T_world_object(1, 3).has_value());
  EXPECT_TRUE(seq.T_world_object(1, 6).has_value());
  EXPECT_FALSE(seq.T_world_object(1, 7).has_value());
  EXPECT_EQ(seq.object_trajectory(1).size(), 4u);
  EXPECT_THROW(seq.T_world_object(2, 0), Error);
  EXPECT_THROW(seq.T_world_camera(10), Error);
  const RenderedFrame absent = seq.render(0);
  EXPECT_EQ(cv::countNonZero(absent.instance_ids), 0);
  const RenderedFrame present = seq.render(4);
  EXPECT_GT(cv::countNonZero(present.instance_ids), 100);
}

TEST(SyntheticSequence, SeedOverridesOnlyTheNoise) {
  const SceneDescription s = load_scene("one_object");
  SyntheticSequence a(s), b(s, 12345), c(s, 0, 7);
  EXPECT_EQ(a.noise_seed(), s.seed);
  EXPECT_EQ(b.noise_seed(), 12345u);
  EXPECT_EQ(c.size(), 7);
  for (int f : {0, 30, 90}) {
    EXPECT_TRUE(a.T_world_camera(f).isApprox(b.T_world_camera(f), 0));
    EXPECT_TRUE(a.T_world_object(1, f)->isApprox(*b.T_world_object(1, f), 0));
  }
}

}  // namespace
}  // namespace cofusion::synthetic
