#include "eval/geometry_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <cstring>
#include <fstream>

#include "common/error.h"
#include "support/test_support.h"

namespace cofusion::eval {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

void write_file(const fs::path& p, const std::string& bytes) {
  std::ofstream f(p, std::ios::binary);
  f << bytes;
}

template <typename T>
void append(std::string& out, T value, bool big_endian = false) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  if (big_endian) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

TEST(PlyReader, AsciiWithExtraPropertiesAndFaces) {
  const auto dir = test::fresh_temp_dir();
  write_file(dir / "a.ply",
             "ply\r\nformat ascii 1.0\r\ncomment made by a test\r\nelement vertex 3\r\n"
             "property float nx\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\nproperty uchar red\r\n"
             "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
             "9 1.5 -2 3e-1 255\r\n0 0 0 0 0\r\n1 4.25 5 6 7\r\n3 0 1 2\r\n");
  const auto pts = read_ply_points(dir / "a.ply");
  ASSERT_EQ(pts.size(), 3u);
  EXPECT_TRUE(pts[0].isApprox(Eigen::Vector3d(1.5, -2, 0.3)));
  EXPECT_TRUE(pts[2].isApprox(Eigen::Vector3d(4.25, 5, 6)));
}

TEST(PlyReader, BinaryLittleEndianAfterAnotherElement) {
  const auto dir = test::fresh_temp_dir();
  std::string data =
      "ply\nformat binary_little_endian 1.0\nelement camera 1\nproperty list uchar float k\n"
      "element vertex 2\nproperty double x\nproperty float y\nproperty short z\nproperty float radius\nend_header\n";
  // camera: a list of two floats
  append<std::uint8_t>(data, 2);
  append<float>(data, 1.f);
  append<float>(data, 2.f);
  for (int i = 0; i < 2; ++i) {
    append<double>(data, 0.125 + i);
    append<float>(data, -1.5f * static_cast<float>(i));
    append<std::int16_t>(data, static_cast<std::int16_t>(-7 + i));
    append<float>(data, 0.01f);
  }
  write_file(dir / "b.ply", data);
  const auto pts = read_ply_points(dir / "b.ply");
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts[0], Eigen::Vector3d(0.125, 0, -7));
  EXPECT_EQ(pts[1], Eigen::Vector3d(1.125, -1.5, -6));

  // The same record truncated by a byte.
  write_file(dir / "short.ply", data.substr(0, data.size() - 1));
  try {
    read_ply_points(dir / "short.ply");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("short.ply"), std::string::npos) << e.what();
  }
}

TEST(PlyReader, BinaryBigEndian) {
  const auto dir = test::fresh_temp_dir();
  std::string data = "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  append<float>(data, 1.f, true);
  append<float>(data, 2.f, true);
  append<float>(data, 3.f, true);
  write_file(dir / "c.ply", data);
  EXPECT_EQ(read_ply_points(dir / "c.ply").at(0), Eigen::Vector3d(1, 2, 3));
}

TEST(PlyReader, BadInputs) {
  const auto dir = test::fresh_temp_dir();
  EXPECT_THROW(read_ply_points(dir / "missing.ply"), Error);
  write_file(dir / "notply.ply", "solid stl\n");
  EXPECT_THROW(read_ply_points(dir / "notply.ply"), Error);
  write_file(dir / "noz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n");
  EXPECT_THROW(read_ply_points(dir / "noz.ply"), Error);
  write_file(dir / "noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
  EXPECT_THROW(read_ply_points(dir / "noend.ply"), Error);
  write_file(dir / "text.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 five 6\n");
  EXPECT_THROW(read_ply_points(dir / "text.ply"), Error);
  write_file(dir / "nan.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\nnan 2 3\n");
  EXPECT_THROW(read_ply_points(dir / "nan.ply"), Error);
}

// Found by fuzz_ply: an element before the vertices with a huge count and no properties was walked
// instance by instance (10^14 empty steps); an ascii list length of 1e300 would be cast past the
// integers' range. Both end at once now: the element holds no data, the list runs past the file.
TEST(PlyReader, HugeCountsBeforeTheVerticesEndAtOnce) {
  const auto dir = test::fresh_temp_dir();
  write_file(dir / "empty_element.ply", "ply\nformat ascii 1.0\nelement face 66666666666666\nelement vertex 1\n"
                                        "property float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n");
  const auto points = read_ply_points(dir / "empty_element.ply");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points[0], Eigen::Vector3d(1, 2, 3));
  write_file(dir / "long_list.ply", "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
                                    "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                                    "end_header\n1e300 0 0 0\n1 2 3\n");
  const std::string msg = test::error_of([&] { read_ply_points(dir / "long_list.ply"); });
  EXPECT_THAT(msg, HasSubstr("long_list.ply: face 0"));
  EXPECT_THAT(msg, HasSubstr("runs past the end of the file"));
}

// A glTF model with one triangle mesh (a unit square in z = 0 as two triangles, ushort indices)
// used by a child node, under a translated parent; plus a POINTS primitive that must be skipped.
tinygltf::Model square_model() {
  tinygltf::Model model;
  const float positions[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  const std::uint16_t indices[] = {0, 1, 2, 0, 2, 3};
  tinygltf::Buffer buffer;
  buffer.data.resize(sizeof positions + sizeof indices);
  std::memcpy(buffer.data.data(), positions, sizeof positions);
  std::memcpy(buffer.data.data() + sizeof positions, indices, sizeof indices);
  model.buffers.push_back(buffer);
  tinygltf::BufferView pos_view;
  pos_view.buffer = 0;
  pos_view.byteOffset = 0;
  pos_view.byteLength = sizeof positions;
  pos_view.target = TINYGLTF_TARGET_ARRAY_BUFFER;
  tinygltf::BufferView idx_view;
  idx_view.buffer = 0;
  idx_view.byteOffset = sizeof positions;
  idx_view.byteLength = sizeof indices;
  idx_view.target = TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER;
  model.bufferViews = {pos_view, idx_view};
  tinygltf::Accessor pos;
  pos.bufferView = 0;
  pos.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  pos.count = 4;
  pos.type = TINYGLTF_TYPE_VEC3;
  pos.minValues = {0, 0, 0};
  pos.maxValues = {1, 1, 0};
  tinygltf::Accessor idx;
  idx.bufferView = 1;
  idx.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
  idx.count = 6;
  idx.type = TINYGLTF_TYPE_SCALAR;
  model.accessors = {pos, idx};
  tinygltf::Primitive tris;
  tris.attributes["POSITION"] = 0;
  tris.indices = 1;
  tris.mode = TINYGLTF_MODE_TRIANGLES;
  tinygltf::Primitive points;
  points.attributes["POSITION"] = 0;
  points.mode = TINYGLTF_MODE_POINTS;
  tinygltf::Mesh mesh;
  mesh.primitives = {tris, points};
  model.meshes.push_back(mesh);
  tinygltf::Node parent, child;
  parent.translation = {10, 0, 0};
  parent.children = {1};
  child.mesh = 0;
  child.scale = {2, 2, 2};
  child.rotation = {0, 0, std::sin(std::numbers::pi / 4), std::cos(std::numbers::pi / 4)};  // 90 deg about z
  model.nodes = {parent, child};
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  model.asset.version = "2.0";
  return model;
}

TEST(GltfReader, TrianglesWithNodeTransformsGlbAndGltf) {
  const auto dir = test::fresh_temp_dir();
  const tinygltf::Model model = square_model();
  tinygltf::TinyGLTF writer;
  ASSERT_TRUE(writer.WriteGltfSceneToFile(&model, (dir / "square.glb").string(), true, true, false, true));
  ASSERT_TRUE(writer.WriteGltfSceneToFile(&model, (dir / "square.gltf").string(), true, true, true, false));
  for (const char* name : {"square.glb", "square.gltf"}) {
    const TriangleMesh mesh = read_gltf_triangles(dir / name);
    ASSERT_EQ(mesh.triangles.size(), 2u) << name;
    // world = translate(10,0,0) * rotate_z(90) * scale(2): (1,0,0) -> (10, 2, 0), (1,1,0) -> (8, 2, 0).
    ASSERT_EQ(mesh.vertices.size(), 4u);
    EXPECT_TRUE(mesh.vertices[1].isApprox(Eigen::Vector3d(10, 2, 0), 1e-6)) << mesh.vertices[1].transpose();
    EXPECT_TRUE(mesh.vertices[2].isApprox(Eigen::Vector3d(8, 2, 0), 1e-6)) << mesh.vertices[2].transpose();
    EXPECT_EQ(mesh.triangles[1], Eigen::Vector3i(0, 2, 3));
  }
}

TEST(GltfReader, BadInputs) {
  const auto dir = test::fresh_temp_dir();
  EXPECT_THROW(read_gltf_triangles(dir / "missing.glb"), Error);
  write_file(dir / "garbage.glb", "this is not glTF");
  EXPECT_THROW(read_gltf_triangles(dir / "garbage.glb"), Error);
  write_file(dir / "garbage.gltf", "{ not json");
  EXPECT_THROW(read_gltf_triangles(dir / "garbage.gltf"), Error);

  // Only a POINTS primitive: no triangles.
  tinygltf::Model points_only = square_model();
  points_only.meshes[0].primitives.erase(points_only.meshes[0].primitives.begin());
  tinygltf::TinyGLTF writer;
  ASSERT_TRUE(writer.WriteGltfSceneToFile(&points_only, (dir / "points.glb").string(), true, true, false, true));
  try {
    read_gltf_triangles(dir / "points.glb");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("points.glb"), std::string::npos) << e.what();
  }

  // An index past the vertex count.
  tinygltf::Model bad_index = square_model();
  bad_index.buffers[0].data[48] = 9;  // first index (ushort, little-endian) = 9
  ASSERT_TRUE(writer.WriteGltfSceneToFile(&bad_index, (dir / "index.glb").string(), true, true, false, true));
  EXPECT_THROW(read_gltf_triangles(dir / "index.glb"), Error);
}

// Found by fuzz_gltf: a POSITION accessor that does not exist escaped as std::out_of_range; and an
// accessor count so large that count x stride wrapped around passed the bounds check.
TEST(GltfReader, AccessorsOutOfRangeOrTooLongAreErrorsNamingTheFile) {
  const auto dir = test::fresh_temp_dir();
  tinygltf::TinyGLTF writer;
  tinygltf::Model no_accessor = square_model();
  no_accessor.meshes[0].primitives[0].attributes["POSITION"] = 5;
  ASSERT_TRUE(writer.WriteGltfSceneToFile(&no_accessor, (dir / "position.gltf").string(), true, true, true, false));
  std::string msg = test::error_of([&] { read_gltf_triangles(dir / "position.gltf"); });
  EXPECT_THAT(msg, HasSubstr("position.gltf"));
  EXPECT_THAT(msg, HasSubstr("accessor index 5 out of range"));

  tinygltf::Model wrapping = square_model();
  wrapping.accessors[0].count = std::size_t{1} << 62;  // 12 bytes x (2^62 - 1) + 12 = 0 modulo 2^64
  ASSERT_TRUE(writer.WriteGltfSceneToFile(&wrapping, (dir / "count.gltf").string(), true, true, true, false));
  msg = test::error_of([&] { read_gltf_triangles(dir / "count.gltf"); });
  EXPECT_THAT(msg, HasSubstr("count.gltf"));
  EXPECT_THAT(msg, HasSubstr("reads past its buffer"));
}

}  // namespace
}  // namespace cofusion::eval
