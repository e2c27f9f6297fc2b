#pragma once
// Readers for reconstruction evaluation: model points from PLY, ground-truth meshes from glTF 2.0.
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace cofusion::eval {

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;  // indices into vertices
};

// The x, y, z properties of the PLY `vertex` element (any numeric type; other properties and
// elements are skipped). Formats: ascii, binary_little_endian, binary_big_endian. Throws
// cofusion::Error naming the file on a missing file, a malformed header, truncated data, a
// missing x/y/z property or a non-finite coordinate.
std::vector<Eigen::Vector3d> read_ply_points(const std::filesystem::path& path);

// All triangle primitives (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN; points and lines are skipped)
// of the meshes reached from the default scene (or the first scene; or every root node when there
// are no scenes), with node transforms applied; `.glb` binary or `.gltf` text. Throws
// cofusion::Error naming the file when it cannot be loaded, an accessor is out of range or
// unsupported (sparse, non-float positions), or no triangle is found.
TriangleMesh read_gltf_triangles(const std::filesystem::path& path);

}  // namespace cofusion::eval
