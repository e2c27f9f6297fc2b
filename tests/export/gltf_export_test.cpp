#include "export/gltf_export.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <limits>

#include "common/error.h"
#include "export/export_test_util.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;
using test::load_gltf;
using test::read_accessor;

// The surfels `kept` (in order) must be exactly what the node's point mesh holds.
void expect_points_match(const tinygltf::Model& doc, const tinygltf::Node& node, const std::vector<Surfel>& kept) {
  ASSERT_GE(node.mesh, 0);
  const tinygltf::Mesh& mesh = doc.meshes.at(static_cast<std::size_t>(node.mesh));
  ASSERT_EQ(mesh.primitives.size(), 1u);
  const tinygltf::Primitive& prim = mesh.primitives[0];
  EXPECT_EQ(prim.mode, TINYGLTF_MODE_POINTS);
  for (const char* name : {"POSITION", "NORMAL", "COLOR_0", "_RADIUS", "_CONFIDENCE"})
    ASSERT_EQ(prim.attributes.count(name), 1u) << name;

  const tinygltf::Accessor& pos_acc = doc.accessors.at(static_cast<std::size_t>(prim.attributes.at("POSITION")));
  const tinygltf::Accessor& col_acc = doc.accessors.at(static_cast<std::size_t>(prim.attributes.at("COLOR_0")));
  EXPECT_EQ(pos_acc.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
  EXPECT_EQ(pos_acc.type, TINYGLTF_TYPE_VEC3);
  EXPECT_EQ(col_acc.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE);
  EXPECT_EQ(col_acc.type, TINYGLTF_TYPE_VEC4);
  EXPECT_TRUE(col_acc.normalized);
  ASSERT_EQ(pos_acc.count, kept.size());

  const auto pos = read_accessor<float>(doc, prim.attributes.at("POSITION"), 3);
  const auto nrm = read_accessor<float>(doc, prim.attributes.at("NORMAL"), 3);
  const auto col = read_accessor<std::uint8_t>(doc, prim.attributes.at("COLOR_0"), 4);
  const auto rad = read_accessor<float>(doc, prim.attributes.at("_RADIUS"), 1);
  const auto con = read_accessor<float>(doc, prim.attributes.at("_CONFIDENCE"), 1);
  ASSERT_EQ(rad.size(), kept.size());
  ASSERT_EQ(con.size(), kept.size());
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity()), hi = -lo;
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const Surfel& s = kept[i];
    EXPECT_EQ(pos[3 * i + 0], s.px);
    EXPECT_EQ(pos[3 * i + 1], s.py);
    EXPECT_EQ(pos[3 * i + 2], s.pz);
    const Eigen::Vector3d n(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]);
    EXPECT_NEAR(n.norm(), 1.0, 1e-6);
    EXPECT_LT((n - test::unit_normal(s)).norm(), 1e-6) << "surfel " << i;
    EXPECT_EQ(col[4 * i + 0], s.colour_rgba8 & 0xff);
    EXPECT_EQ(col[4 * i + 1], (s.colour_rgba8 >> 8) & 0xff);
    EXPECT_EQ(col[4 * i + 2], (s.colour_rgba8 >> 16) & 0xff);
    EXPECT_EQ(col[4 * i + 3], 255);  // opaque whatever the alpha byte held
    EXPECT_EQ(rad[i], s.radius_m);
    EXPECT_EQ(con[i], s.confidence);
    lo = lo.cwiseMin(Eigen::Vector3f(s.px, s.py, s.pz));
    hi = hi.cwiseMax(Eigen::Vector3f(s.px, s.py, s.pz));
  }
  ASSERT_EQ(pos_acc.minValues.size(), 3u);
  ASSERT_EQ(pos_acc.maxValues.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(pos_acc.minValues[static_cast<std::size_t>(k)], double(lo[k]));
    EXPECT_EQ(pos_acc.maxValues[static_cast<std::size_t>(k)], double(hi[k]));
  }
}

void expect_matrix_is_pose(const tinygltf::Node& node, const Eigen::Isometry3d& T) {
  ASSERT_EQ(node.matrix.size(), 16u);
  const Eigen::Map<const Eigen::Matrix4d> m(node.matrix.data());  // column-major, as glTF
  EXPECT_LT((m - T.matrix()).cwiseAbs().maxCoeff(), 1e-12) << m;
}

TEST(GltfExport, GlbRoundTripMatchesSurfels) {
  const fs::path dir = test::fresh_temp_dir();
  const SurfelCloud model = test::sample_model(3, 400, "cup");
  write_model_gltf(model, dir / "model-3.glb");
  EXPECT_EQ(test::entries(dir), std::set<std::string>{"model-3.glb"});

  const tinygltf::Model doc = load_gltf(dir / "model-3.glb");
  EXPECT_EQ(doc.asset.version, "2.0");
  ASSERT_EQ(doc.scenes.size(), 1u);
  ASSERT_EQ(doc.nodes.size(), 1u);
  ASSERT_EQ(doc.buffers.size(), 1u);
  EXPECT_TRUE(doc.buffers[0].uri.empty());  // GLB: the buffer is the BIN chunk
  const tinygltf::Node& node = doc.nodes[0];
  EXPECT_EQ(node.name, "model-3-cup");
  expect_matrix_is_pose(node, model.T_world_model);
  expect_points_match(doc, node, model.surfels);
  const tinygltf::Value& info = node.extras.Get("cofusion");
  EXPECT_EQ(info.Get("model_id").GetNumberAsInt(), 3);
  EXPECT_EQ(info.Get("class_name").Get<std::string>(), "cup");
  EXPECT_EQ(info.Get("state").Get<std::string>(), "active");
}

TEST(GltfExport, GltfPlusBinRoundTrip) {
  const fs::path dir = test::fresh_temp_dir();
  const SurfelCloud model = test::sample_model(7, 123);
  write_model_gltf(model, dir / "model-7.gltf", {.container = GltfContainer::GltfPlusBin});
  EXPECT_EQ(test::entries(dir), (std::set<std::string>{"model-7.gltf", "model-7.bin"}));

  std::ifstream json(dir / "model-7.gltf");
  const std::string text((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"uri\": \"model-7.bin\""), std::string::npos) << "buffer must be external";
  const tinygltf::Model doc = load_gltf(dir / "model-7.gltf");
  ASSERT_EQ(doc.nodes.size(), 1u);
  EXPECT_EQ(doc.nodes[0].name, "model-7");
  ASSERT_EQ(doc.buffers.size(), 1u);
  EXPECT_EQ(doc.buffers[0].data.size(), fs::file_size(dir / "model-7.bin"));
  expect_matrix_is_pose(doc.nodes[0], model.T_world_model);
  expect_points_match(doc, doc.nodes[0], model.surfels);
}

TEST(GltfExport, ConfidenceThresholdKeepsOnlyConfidentSurfels) {
  const fs::path dir = test::fresh_temp_dir();
  const SurfelCloud model = test::sample_model(1, 300);
  std::vector<Surfel> expected;
  for (const Surfel& s : model.surfels)
    if (s.confidence >= 4.0f) expected.push_back(s);
  ASSERT_GT(expected.size(), 50u);
  ASSERT_LT(expected.size(), model.surfels.size() - 50);
  write_model_gltf(model, dir / "m.glb", {.min_confidence = 4.0f});
  const tinygltf::Model doc = load_gltf(dir / "m.glb");
  expect_points_match(doc, doc.nodes.at(0), expected);
}

TEST(GltfExport, SurfelsWithZeroNormalOrNonFiniteValuesAreLeftOut) {
  const fs::path dir = test::fresh_temp_dir();
  SurfelCloud model = test::sample_model(2, 10);
  std::vector<Surfel> expected = model.surfels;
  Surfel zero_normal = model.surfels[0];
  zero_normal.nx = zero_normal.ny = zero_normal.nz = 0.0f;
  Surfel nan_position = model.surfels[1];
  nan_position.py = std::numeric_limits<float>::quiet_NaN();
  Surfel inf_radius = model.surfels[2];
  inf_radius.radius_m = std::numeric_limits<float>::infinity();
  model.surfels.insert(model.surfels.begin() + 3, {zero_normal, nan_position, inf_radius});
  write_model_gltf(model, dir / "m.glb");
  const tinygltf::Model doc = load_gltf(dir / "m.glb");
  expect_points_match(doc, doc.nodes.at(0), expected);
}

TEST(GltfExport, ModelWithoutSurfelsIsNodeWithoutMesh) {
  const fs::path dir = test::fresh_temp_dir();
  SurfelCloud empty;
  empty.model_id = 4;
  empty.T_world_model = test::sample_pose();
  SurfelCloud all_filtered = test::sample_model(5, 20);
  for (const GltfContainer container : {GltfContainer::Glb, GltfContainer::GltfPlusBin}) {
    const std::string ext = container == GltfContainer::Glb ? ".glb" : ".gltf";
    write_model_gltf(empty, dir / ("empty" + ext), {.container = container});
    write_model_gltf(all_filtered, dir / ("filtered" + ext), {.min_confidence = 100.0f, .container = container});
    for (const std::string stem : {"empty", "filtered"}) {
      const tinygltf::Model doc = load_gltf(dir / (stem + ext));
      ASSERT_EQ(doc.nodes.size(), 1u) << stem << ext;
      EXPECT_EQ(doc.nodes[0].mesh, -1);
      EXPECT_EQ(doc.nodes[0].matrix.size(), 16u);
      EXPECT_TRUE(doc.meshes.empty());
      EXPECT_TRUE(doc.accessors.empty());
      EXPECT_TRUE(doc.buffers.empty());  // glTF forbids zero-length buffers
    }
  }
  EXPECT_FALSE(fs::exists(dir / "empty.bin"));  // no buffer, no .bin

  // Re-exporting a model that lost its surfels removes its now stale .bin.
  write_model_gltf(test::sample_model(5, 20), dir / "again.gltf", {.container = GltfContainer::GltfPlusBin});
  ASSERT_TRUE(fs::exists(dir / "again.bin"));
  write_model_gltf(empty, dir / "again.gltf", {.container = GltfContainer::GltfPlusBin});
  EXPECT_FALSE(fs::exists(dir / "again.bin"));
  EXPECT_TRUE(load_gltf(dir / "again.gltf").buffers.empty());
}

TEST(GltfExport, IdentityPoseIsWrittenAsNoMatrix) {
  const fs::path dir = test::fresh_temp_dir();
  SurfelCloud model = test::sample_model(0, 5);
  model.T_world_model = Eigen::Isometry3d::Identity();
  write_model_gltf(model, dir / "m.glb");
  const tinygltf::Model doc = load_gltf(dir / "m.glb");
  EXPECT_TRUE(doc.nodes.at(0).matrix.empty());  // glTF's default transform
}

TEST(GltfExport, SceneHoldsEveryModelAndTheCameraTrajectory) {
  const fs::path dir = test::fresh_temp_dir();
  std::vector<SurfelCloud> models = {test::sample_model(0, 200), test::sample_model(2, 50, "teddy bear"),
                                     test::sample_model(5, 0)};
  Trajectory camera;
  for (int i = 0; i < 6; ++i) {
    TimedPose p;
    p.timestamp_s = 0.1 * i;
    p.T_world_x = test::sample_pose(0.1 * i);
    p.T_world_x.translation() += Eigen::Vector3d(0.05 * i, 0.01 * i * i, -0.02 * i);
    camera.push_back(p);
  }
  write_scene_gltf(models, camera, dir / "scene.glb");

  const tinygltf::Model doc = load_gltf(dir / "scene.glb");
  ASSERT_EQ(doc.nodes.size(), 4u);
  ASSERT_EQ(doc.scenes.at(0).nodes.size(), 4u);
  EXPECT_EQ(doc.nodes[0].name, "model-0");
  EXPECT_EQ(doc.nodes[1].name, "model-2-teddy_bear");
  EXPECT_EQ(doc.nodes[2].name, "model-5");
  EXPECT_EQ(doc.nodes[2].mesh, -1);
  for (int i = 0; i < 2; ++i) {
    expect_matrix_is_pose(doc.nodes[static_cast<std::size_t>(i)], models[static_cast<std::size_t>(i)].T_world_model);
    expect_points_match(doc, doc.nodes[static_cast<std::size_t>(i)], models[static_cast<std::size_t>(i)].surfels);
  }

  const tinygltf::Node& path_node = doc.nodes[3];
  EXPECT_EQ(path_node.name, "camera-trajectory");
  EXPECT_TRUE(path_node.matrix.empty());  // world coordinates
  const tinygltf::Primitive& line = doc.meshes.at(static_cast<std::size_t>(path_node.mesh)).primitives.at(0);
  EXPECT_EQ(line.mode, TINYGLTF_MODE_LINE_STRIP);
  const auto xyz = read_accessor<float>(doc, line.attributes.at("POSITION"), 3);
  ASSERT_EQ(xyz.size(), 3 * camera.size());
  for (std::size_t i = 0; i < camera.size(); ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(xyz[3 * i + static_cast<std::size_t>(k)], static_cast<float>(camera[i].T_world_x.translation()[k]));
}

TEST(GltfExport, SceneLeavesOutTrajectoryWithFewerThanTwoPoses) {
  const fs::path dir = test::fresh_temp_dir();
  write_scene_gltf({test::sample_model(1, 10)}, std::vector<Eigen::Vector3d>{Eigen::Vector3d(1, 2, 3)},
                   dir / "scene.glb");
  const tinygltf::Model doc = load_gltf(dir / "scene.glb");
  ASSERT_EQ(doc.nodes.size(), 1u);
  EXPECT_EQ(doc.nodes[0].name, "model-1");
}

// The message names the target and nothing is left in (or beside) the target folder.
void expect_unwritable(const fs::path& target, GltfContainer container) {
  try {
    write_model_gltf(test::sample_model(1, 10), target, {.container = container});
    FAIL() << "expected cofusion::Error for " << target;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(target.string()), std::string::npos) << e.what();
  }
}

TEST(GltfExport, UnwritableTargetThrowsNamingPathAndLeavesNothing) {
  const fs::path dir = test::fresh_temp_dir();
  // A path below a regular file cannot be created, even by root.
  std::ofstream(dir / "plain-file") << "x";
  for (const GltfContainer c : {GltfContainer::Glb, GltfContainer::GltfPlusBin})
    expect_unwritable(dir / "plain-file" / "sub" / (c == GltfContainer::Glb ? "m.glb" : "m.gltf"), c);
  EXPECT_EQ(test::entries(dir), std::set<std::string>{"plain-file"});

  // A read-only folder (root ignores permissions, so only checked for other users).
  if (::geteuid() != 0) {
    const fs::path ro = dir / "read-only";
    fs::create_directory(ro);
    fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
    for (const GltfContainer c : {GltfContainer::Glb, GltfContainer::GltfPlusBin})
      expect_unwritable(ro / (c == GltfContainer::Glb ? "m.glb" : "m.gltf"), c);
    fs::permissions(ro, fs::perms::owner_all);
    EXPECT_TRUE(test::entries(ro).empty());
  }
}

TEST(GltfExport, NonFinitePoseThrowsNamingFileAndModel) {
  const fs::path dir = test::fresh_temp_dir();
  SurfelCloud model = test::sample_model(9, 10);
  model.T_world_model.translation().x() = std::numeric_limits<double>::quiet_NaN();
  try {
    write_model_gltf(model, dir / "m.glb");
    FAIL() << "expected cofusion::Error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find((dir / "m.glb").string()), std::string::npos) << what;
    EXPECT_NE(what.find("model-9"), std::string::npos) << what;
  }
  EXPECT_TRUE(test::entries(dir).empty());
}

}  // namespace
}  // namespace cofusion
