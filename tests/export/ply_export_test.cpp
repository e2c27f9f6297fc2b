#include "export/ply_export.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <fstream>
#include <numbers>

#include "common/error.h"
#include "export/export_test_util.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;

std::string read_all(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void expect_rgb(const Surfel& got, const Surfel& want) {
  EXPECT_EQ(got.colour_rgba8 & 0xffffffu, want.colour_rgba8 & 0xffffffu);
  EXPECT_EQ(got.colour_rgba8 >> 24, 255u);  // PLY has no alpha: read back as opaque
}

TEST(PlyExport, ModelFrameRoundTrip) {
  const fs::path dir = test::fresh_temp_dir();
  SurfelCloud model = test::sample_model(6, 300, "keyboard");
  model.state = ModelState::Inactive;
  write_model_ply(model, dir / "model-6.ply");
  EXPECT_EQ(test::entries(dir), std::set<std::string>{"model-6.ply"});

  const PlyModel back = read_surfel_ply(dir / "model-6.ply");
  EXPECT_EQ(back.frame, PlyFrame::Model);
  EXPECT_EQ(back.cloud.model_id, 6);
  EXPECT_EQ(back.cloud.class_name, "keyboard");
  EXPECT_EQ(back.cloud.state, ModelState::Inactive);
  EXPECT_TRUE(back.cloud.T_world_model.matrix() == model.T_world_model.matrix());  // %.17g is exact
  ASSERT_EQ(back.cloud.surfels.size(), model.surfels.size());
  for (std::size_t i = 0; i < model.surfels.size(); ++i) {
    const Surfel& s = model.surfels[i];
    const Surfel& r = back.cloud.surfels[i];
    EXPECT_EQ(r.px, s.px);
    EXPECT_EQ(r.py, s.py);
    EXPECT_EQ(r.pz, s.pz);
    EXPECT_LT((Eigen::Vector3d(r.nx, r.ny, r.nz) - test::unit_normal(s)).norm(), 1e-6);
    expect_rgb(r, s);
    EXPECT_EQ(r.radius_m, s.radius_m);
    EXPECT_EQ(r.confidence, s.confidence);
  }
}

TEST(PlyExport, WorldFrameAppliesPoseToPositionsAndNormals) {
  const fs::path dir = test::fresh_temp_dir();
  SurfelCloud model = test::sample_model(2, 200);
  // A quarter turn about z: the model's +x normal must come out as world +y.
  model.T_world_model = Eigen::Isometry3d::Identity();
  model.T_world_model.linear() = Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  model.T_world_model.translation() = Eigen::Vector3d(1.0, 2.0, -0.5);
  model.surfels[0].px = 1.0f;
  model.surfels[0].py = 0.0f;
  model.surfels[0].pz = 0.0f;
  model.surfels[0].nx = 2.0f;  // not unit: renormalised
  model.surfels[0].ny = 0.0f;
  model.surfels[0].nz = 0.0f;
  write_model_ply(model, dir / "world.ply", {.frame = PlyFrame::World});

  const PlyModel back = read_surfel_ply(dir / "world.ply");
  EXPECT_EQ(back.frame, PlyFrame::World);
  ASSERT_EQ(back.cloud.surfels.size(), model.surfels.size());
  const Surfel& first = back.cloud.surfels[0];
  EXPECT_NEAR(first.px, 1.0f, 1e-6);
  EXPECT_NEAR(first.py, 3.0f, 1e-6);
  EXPECT_NEAR(first.pz, -0.5f, 1e-6);
  EXPECT_NEAR(first.nx, 0.0f, 1e-6);
  EXPECT_NEAR(first.ny, 1.0f, 1e-6);
  EXPECT_NEAR(first.nz, 0.0f, 1e-6);

  // Every surfel, against a general rotation about a skewed axis.
  model.T_world_model = test::sample_pose(2.1);
  write_model_ply(model, dir / "world2.ply", {.frame = PlyFrame::World});
  const PlyModel back2 = read_surfel_ply(dir / "world2.ply");
  const Eigen::Matrix3d R = model.T_world_model.rotation();
  double largest_normal_change = 0;
  for (std::size_t i = 0; i < model.surfels.size(); ++i) {
    const Surfel& s = model.surfels[i];
    const Surfel& r = back2.cloud.surfels[i];
    const Eigen::Vector3d p_world = model.T_world_model * Eigen::Vector3d(s.px, s.py, s.pz);
    EXPECT_LT((Eigen::Vector3d(r.px, r.py, r.pz) - p_world).norm(), 1e-6);
    const Eigen::Vector3d n_world(r.nx, r.ny, r.nz);
    EXPECT_LT((n_world - R * test::unit_normal(s)).norm(), 1e-6);
    EXPECT_NEAR(n_world.norm(), 1.0, 1e-6);
    largest_normal_change = std::max(largest_normal_change, (n_world - test::unit_normal(s)).norm());
    expect_rgb(r, s);
    EXPECT_EQ(r.radius_m, s.radius_m);
    EXPECT_EQ(r.confidence, s.confidence);
  }
  EXPECT_GT(largest_normal_change, 0.5);  // the rotation really moved the normals
}

TEST(PlyExport, BinaryLayoutIsLittleEndian35BytesPerVertex) {
  const fs::path dir = test::fresh_temp_dir();
  SurfelCloud model;
  model.model_id = 12;
  Surfel s{};
  s.px = 1.5f;
  s.py = -2.0f;
  s.pz = 0.25f;
  s.nz = 1.0f;
  s.radius_m = 0.01f;
  s.confidence = 3.0f;
  s.colour_rgba8 = test::pack_rgba(10, 20, 30, 0);
  model.surfels = {s, s};
  write_model_ply(model, dir / "m.ply");

  const std::string bytes = read_all(dir / "m.ply");
  const std::string end = "end_header\n";
  const auto header_end = bytes.find(end);
  ASSERT_NE(header_end, std::string::npos);
  const std::string header = bytes.substr(0, header_end + end.size());
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u) << header;
  EXPECT_NE(header.find("element vertex 2\n"), std::string::npos);
  EXPECT_NE(header.find("property float x\nproperty float y\nproperty float z\n"
                        "property float nx\nproperty float ny\nproperty float nz\n"
                        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                        "property float radius\nproperty float confidence\nend_header\n"),
            std::string::npos)
      << header;
  ASSERT_EQ(bytes.size(), header.size() + 2 * 35);
  const auto* v = reinterpret_cast<const unsigned char*>(bytes.data() + header.size());
  const std::uint32_t x_bits = std::bit_cast<std::uint32_t>(1.5f);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(v[i], (x_bits >> (8 * i)) & 0xff) << "byte " << i;
  EXPECT_EQ(v[24], 10);
  EXPECT_EQ(v[25], 20);
  EXPECT_EQ(v[26], 30);
}

TEST(PlyExport, ConfidenceThresholdAndInvalidSurfels) {
  const fs::path dir = test::fresh_temp_dir();
  SurfelCloud model = test::sample_model(1, 300);
  model.surfels[7].nx = model.surfels[7].ny = model.surfels[7].nz = 0.0f;  // no normal: dropped
  std::vector<Surfel> expected;
  for (std::size_t i = 0; i < model.surfels.size(); ++i)
    if (model.surfels[i].confidence >= 5.0f && i != 7) expected.push_back(model.surfels[i]);
  write_model_ply(model, dir / "m.ply", {.min_confidence = 5.0f});
  const PlyModel back = read_surfel_ply(dir / "m.ply");
  ASSERT_EQ(back.cloud.surfels.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(back.cloud.surfels[i].px, expected[i].px);
    EXPECT_GE(back.cloud.surfels[i].confidence, 5.0f);
  }
}

TEST(PlyExport, EmptyModelRoundTrips) {
  const fs::path dir = test::fresh_temp_dir();
  SurfelCloud model;
  model.model_id = 8;
  write_model_ply(model, dir / "m.ply");
  const PlyModel back = read_surfel_ply(dir / "m.ply");
  EXPECT_EQ(back.cloud.model_id, 8);
  EXPECT_TRUE(back.cloud.surfels.empty());
}

TEST(PlyExport, ReaderAcceptsOtherScalarTypesAndLeadingElements) {
  const fs::path dir = test::fresh_temp_dir();
  std::string file =
      "ply\r\nformat binary_little_endian 1.0\r\ncomment from another tool\r\n"
      "element camera 1\r\nproperty ushort id\r\n"
      "element vertex 1\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\n"
      "property uchar red\r\nproperty short extra\r\nend_header\r\n";
  file += std::string("\x07\x00", 2);  // the camera element: 2 bytes skipped
  for (const double value : {1.25, -3.5, 0.125})
    for (int i = 0; i < 8; ++i)
      file.push_back(static_cast<char>((std::bit_cast<std::uint64_t>(value) >> (8 * i)) & 0xff));
  file += std::string("\xc8\x01\x02", 3);  // red = 200, extra = 0x0201
  std::ofstream(dir / "other.ply", std::ios::binary) << file;

  const PlyModel back = read_surfel_ply(dir / "other.ply");
  ASSERT_EQ(back.cloud.surfels.size(), 1u);
  const Surfel& s = back.cloud.surfels[0];
  EXPECT_EQ(s.px, 1.25f);
  EXPECT_EQ(s.py, -3.5f);
  EXPECT_EQ(s.pz, 0.125f);
  EXPECT_EQ(s.colour_rgba8, test::pack_rgba(200, 255, 255, 255));  // missing green/blue: white
  EXPECT_EQ(s.nx, 0.0f);
  EXPECT_EQ(s.radius_m, 0.0f);
}

TEST(PlyExport, ReaderReadsAsciiFilesWithTheirComments) {
  const fs::path dir = test::fresh_temp_dir();
  std::ofstream(dir / "a.ply") << "ply\nformat ascii 1.0\ncomment model_id 4\ncomment class_name coffee mug\n"
                                  "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                                  "property uchar red\nproperty list uchar int extra\nend_header\n"
                                  "1 2 3 10 2 7 8\n-1 -2 -3.5 20 0\n";
  const PlyModel back = read_surfel_ply(dir / "a.ply");
  EXPECT_EQ(back.cloud.model_id, 4);
  EXPECT_EQ(back.cloud.class_name, "coffee mug");
  ASSERT_EQ(back.cloud.surfels.size(), 2u);
  EXPECT_EQ(back.cloud.surfels[1].pz, -3.5f);
  EXPECT_EQ(back.cloud.surfels[1].colour_rgba8, test::pack_rgba(20, 255, 255, 255));
}

void expect_read_error(const fs::path& path, const std::string& content, const std::string& expected_words) {
  if (!content.empty()) std::ofstream(path, std::ios::binary) << content;
  try {
    read_surfel_ply(path);
    FAIL() << "expected cofusion::Error for " << path;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path.string()), std::string::npos) << what;
    EXPECT_NE(what.find(expected_words), std::string::npos) << what;
  }
}

TEST(PlyExport, ReaderRejectsBadFilesNamingThem) {
  const fs::path dir = test::fresh_temp_dir();
  expect_read_error(dir / "missing.ply", "", "cannot open");
  expect_read_error(dir / "not.ply", "solid cube\n", "not a PLY file");
  expect_read_error(dir / "odd.ply", "ply\nformat binary_middle_endian 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
                    "unknown PLY format");
  expect_read_error(dir / "noend.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1\n", "end_header");
  expect_read_error(dir / "noxyz.ply",
                    "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float q\nend_header\n1234",
                    "lacks x, y or z");

  // A real file cut short.
  write_model_ply(test::sample_model(1, 50), dir / "cut.ply");
  const std::string whole = read_all(dir / "cut.ply");
  fs::remove(dir / "cut.ply");
  expect_read_error(dir / "cut.ply", whole.substr(0, whole.size() - 10), "truncated");
}

TEST(PlyExport, UnwritableTargetThrowsNamingPathAndLeavesNothing) {
  const fs::path dir = test::fresh_temp_dir();
  std::ofstream(dir / "plain-file") << "x";
  const fs::path target = dir / "plain-file" / "sub" / "m.ply";  // fails even for root
  try {
    write_model_ply(test::sample_model(1, 10), target);
    FAIL() << "expected cofusion::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(target.string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(test::entries(dir), std::set<std::string>{"plain-file"});

  if (::geteuid() != 0) {  // root ignores permissions
    const fs::path ro = dir / "read-only";
    fs::create_directory(ro);
    fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
    EXPECT_THROW(write_model_ply(test::sample_model(1, 10), ro / "m.ply"), Error);
    fs::permissions(ro, fs::perms::owner_all);
    EXPECT_TRUE(test::entries(ro).empty());
  }
}

}  // namespace
}  // namespace cofusion
