#pragma once
// Sample models and glTF read-back helpers shared by the export tests.
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "common/surfel_cloud.h"

namespace cofusion::test {

// A rotation about a skewed axis plus a translation: every matrix entry is non-trivial.
inline Eigen::Isometry3d sample_pose(double angle_rad = 0.7) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_rad, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.5, -1.25, 2.0);
  return T;
}

inline std::uint32_t pack_rgba(int r, int g, int b, int a) {
  return std::uint32_t(r) | (std::uint32_t(g) << 8) | (std::uint32_t(b) << 16) | (std::uint32_t(a) << 24);
}

// `count` surfels with reproducible random values; normals deliberately not unit length (the
// writers renormalise), confidence spread over [0, 10), alpha bytes arbitrary.
inline SurfelCloud sample_model(int id, std::size_t count, const std::string& class_name = "",
                                unsigned seed = 1) {
  std::mt19937 rng(seed + static_cast<unsigned>(id));
  std::uniform_real_distribution<float> pos(-1.5f, 1.5f), dir(-1.0f, 1.0f), scale(0.3f, 3.0f);
  std::uniform_real_distribution<float> conf(0.0f, 10.0f), radius(0.001f, 0.02f);
  std::uniform_int_distribution<int> byte(0, 255);
  SurfelCloud cloud;
  cloud.model_id = id;
  cloud.class_name = class_name;
  cloud.T_world_model = sample_pose(0.3 + 0.2 * id);
  for (std::size_t i = 0; i < count; ++i) {
    Surfel s{};
    s.px = pos(rng);
    s.py = pos(rng);
    s.pz = pos(rng);
    Eigen::Vector3f n(dir(rng), dir(rng), dir(rng));
    if (n.norm() < 1e-3f) n = Eigen::Vector3f::UnitZ();
    n *= scale(rng);
    s.nx = n.x();
    s.ny = n.y();
    s.nz = n.z();
    s.confidence = conf(rng);
    s.radius_m = radius(rng);
    s.colour_rgba8 = pack_rgba(byte(rng), byte(rng), byte(rng), byte(rng));
    s.created_frame = static_cast<int>(i);
    s.last_seen_frame = static_cast<int>(i) + 3;
    cloud.surfels.push_back(s);
  }
  return cloud;
}

inline Eigen::Vector3d unit_normal(const Surfel& s) { return Eigen::Vector3d(s.nx, s.ny, s.nz).normalized(); }

// Elements of an accessor as T (component type checked by the caller), honouring byteStride.
template <class T>
std::vector<T> read_accessor(const tinygltf::Model& m, int accessor_index, int components) {
  const tinygltf::Accessor& a = m.accessors.at(static_cast<std::size_t>(accessor_index));
  const tinygltf::BufferView& v = m.bufferViews.at(static_cast<std::size_t>(a.bufferView));
  const tinygltf::Buffer& b = m.buffers.at(static_cast<std::size_t>(v.buffer));
  const std::size_t element = sizeof(T) * static_cast<std::size_t>(components);
  const std::size_t stride = v.byteStride ? v.byteStride : element;
  std::vector<T> out(a.count * static_cast<std::size_t>(components));
  for (std::size_t i = 0; i < a.count; ++i) {
    const std::size_t at = v.byteOffset + a.byteOffset + i * stride;
    EXPECT_LE(at + element, b.data.size());
    std::memcpy(out.data() + i * static_cast<std::size_t>(components), b.data.data() + at, element);
  }
  return out;
}

inline tinygltf::Model load_gltf(const std::filesystem::path& path) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  const bool ok = path.extension() == ".glb" ? loader.LoadBinaryFromFile(&model, &err, &warn, path.string())
                                              : loader.LoadASCIIFromFile(&model, &err, &warn, path.string());
  EXPECT_TRUE(ok) << path << ": " << err;
  EXPECT_TRUE(warn.empty()) << path << ": " << warn;
  return model;
}

// Names of the entries of a folder (to check that no temporary file is left behind).
inline std::set<std::string> entries(const std::filesystem::path& dir) {
  std::set<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

}  // namespace cofusion::test
