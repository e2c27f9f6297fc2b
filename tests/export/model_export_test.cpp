#include "export/model_export.h"

#include <gtest/gtest.h>

#include <fstream>

#include "common/error.h"
#include "export/export_test_util.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;

Trajectory sample_camera(int poses) {
  Trajectory camera;
  for (int i = 0; i < poses; ++i) {
    TimedPose p;
    p.timestamp_s = i / 30.0;
    p.T_world_x.translation() = Eigen::Vector3d(0.02 * i, 0.0, 0.01 * i);
    camera.push_back(p);
  }
  return camera;
}

std::size_t point_count(const tinygltf::Model& doc) {
  if (doc.nodes.at(0).mesh < 0) return 0;
  const auto& prim = doc.meshes.at(static_cast<std::size_t>(doc.nodes[0].mesh)).primitives.at(0);
  return doc.accessors.at(static_cast<std::size_t>(prim.attributes.at("POSITION"))).count;
}

TEST(ModelExport, WritesEveryModelAsGlbAndPlyPlusScene) {
  const fs::path out = test::fresh_temp_dir() / "run-output";  // created by write_models
  std::vector<SurfelCloud> models = {test::sample_model(0, 250), test::sample_model(3, 120, "cup"),
                                     test::sample_model(11, 0)};
  models[1].surfels[4].nx = models[1].surfels[4].ny = models[1].surfels[4].nz = 0.0f;  // dropped everywhere
  const ExportOptions options{.min_confidence = 2.0f};
  const auto written = write_models(models, sample_camera(10), out, options);

  const std::vector<fs::path> expected = {out / "models/model-0.glb",  out / "models/model-0.ply",
                                          out / "models/model-3.glb",  out / "models/model-3.ply",
                                          out / "models/model-11.glb", out / "models/model-11.ply",
                                          out / "scene.glb"};
  EXPECT_EQ(written, expected);
  EXPECT_EQ(test::entries(out), (std::set<std::string>{"models", "scene.glb"}));
  EXPECT_EQ(test::entries(out / "models").size(), 6u);  // no temporaries left

  // The .glb and the .ply of a model hold the same surfels in the same order.
  for (const SurfelCloud& m : models) {
    const std::string stem = "model-" + std::to_string(m.model_id);
    const tinygltf::Model doc = test::load_gltf(out / "models" / (stem + ".glb"));
    const PlyModel ply = read_surfel_ply(out / "models" / (stem + ".ply"));
    std::size_t expected_count = 0;
    for (std::size_t i = 0; i < m.surfels.size(); ++i)
      if (m.surfels[i].confidence >= 2.0f && !(m.model_id == 3 && i == 4)) ++expected_count;
    EXPECT_EQ(point_count(doc), expected_count) << stem;
    ASSERT_EQ(ply.cloud.surfels.size(), expected_count) << stem;
    if (expected_count > 0) {
      const auto& prim = doc.meshes.at(0).primitives.at(0);
      const auto xyz = test::read_accessor<float>(doc, prim.attributes.at("POSITION"), 3);
      for (std::size_t i = 0; i < expected_count; ++i) EXPECT_EQ(xyz[3 * i], ply.cloud.surfels[i].px);
    }
  }
  const tinygltf::Model scene = test::load_gltf(out / "scene.glb");
  ASSERT_EQ(scene.nodes.size(), 4u);
  EXPECT_EQ(scene.nodes[1].name, "model-3-cup");
  EXPECT_EQ(scene.nodes[3].name, "camera-trajectory");
}

TEST(ModelExport, GltfPlusBinAndNoPly) {
  const fs::path out = test::fresh_temp_dir();
  write_models({test::sample_model(1, 30), test::sample_model(2, 0)}, sample_camera(3), out,
               {.gltf_container = GltfContainer::GltfPlusBin, .write_ply = false});
  EXPECT_EQ(test::entries(out / "models"), (std::set<std::string>{"model-1.gltf", "model-1.bin", "model-2.gltf"}));
  EXPECT_EQ(test::entries(out), (std::set<std::string>{"models", "scene.gltf", "scene.bin"}));
  EXPECT_EQ(test::load_gltf(out / "scene.gltf").nodes.size(), 3u);
}

TEST(ModelExport, DuplicateModelIdsThrowBeforeWriting) {
  const fs::path out = test::fresh_temp_dir() / "out";
  EXPECT_THROW(write_models({test::sample_model(4, 5), test::sample_model(4, 6)}, {}, out), Error);
  EXPECT_FALSE(fs::exists(out));
}

TEST(ModelExport, UnwritableOutputFolderThrowsNamingIt) {
  const fs::path dir = test::fresh_temp_dir();
  std::ofstream(dir / "plain-file") << "x";
  const fs::path out = dir / "plain-file" / "out";
  try {
    write_models({test::sample_model(1, 5)}, sample_camera(2), out);
    FAIL() << "expected cofusion::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(out.string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(test::entries(dir), std::set<std::string>{"plain-file"});
}

}  // namespace
}  // namespace cofusion
