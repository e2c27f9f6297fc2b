#include "eval/geometry_io.h"

#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "common/error.h"
#include "io/ply_reader.h"

namespace cofusion::eval {

std::vector<Eigen::Vector3d> read_ply_points(const std::filesystem::path& path) {
  const ply::VertexTable table = ply::read_vertices(path, {"x", "y", "z"});
  std::vector<Eigen::Vector3d> points(table.count);
  for (std::size_t n = 0; n < table.count; ++n) {
    points[n] = Eigen::Vector3d(table.at(n, 0), table.at(n, 1), table.at(n, 2));
    if (!points[n].allFinite())
      throw Error("PLY file " + path.string() + ": vertex " + std::to_string(n) + " has a non-finite coordinate");
  }
  return points;
}

// ---------------------------------------------------------------- glTF

namespace {

Eigen::Matrix4d node_local_matrix(const tinygltf::Node& node) {
  if (node.matrix.size() == 16) {
    Eigen::Matrix4d m;
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m(r, c) = node.matrix[static_cast<std::size_t>(c * 4 + r)];  // column-major
    return m;
  }
  Eigen::Affine3d T = Eigen::Affine3d::Identity();
  if (node.translation.size() == 3) T.translate(Eigen::Vector3d(node.translation[0], node.translation[1], node.translation[2]));
  if (node.rotation.size() == 4)
    T.rotate(Eigen::Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]).normalized());
  if (node.scale.size() == 3) T.scale(Eigen::Vector3d(node.scale[0], node.scale[1], node.scale[2]));
  return T.matrix();
}

class GltfTriangleCollector {
 public:
  GltfTriangleCollector(const tinygltf::Model& model, std::string file) : model_(model), file_(std::move(file)) {}

  void visit(int node_index, const Eigen::Matrix4d& parent, int depth) {
    if (node_index < 0 || node_index >= static_cast<int>(model_.nodes.size()))
      throw Error("glTF file " + file_ + ": node index " + std::to_string(node_index) + " out of range");
    if (depth > 256) throw Error("glTF file " + file_ + ": node hierarchy too deep or cyclic");
    const auto& node = model_.nodes[static_cast<std::size_t>(node_index)];
    const Eigen::Matrix4d world = parent * node_local_matrix(node);
    if (node.mesh >= 0) add_mesh(node.mesh, world);
    for (const int child : node.children) visit(child, world, depth + 1);
  }

  void add_mesh(int mesh_index, const Eigen::Matrix4d& world) {
    if (mesh_index >= static_cast<int>(model_.meshes.size()))
      throw Error("glTF file " + file_ + ": mesh index " + std::to_string(mesh_index) + " out of range");
    for (const auto& prim : model_.meshes[static_cast<std::size_t>(mesh_index)].primitives) add_primitive(prim, world);
  }

  TriangleMesh take() { return std::move(mesh_); }

 private:
  // Byte address of element i of an accessor, with bounds checks against its buffer.
  struct View {
    const unsigned char* base = nullptr;
    std::size_t stride = 0;
    std::size_t count = 0;
  };
  const tinygltf::Accessor& accessor(int index) const {
    if (index < 0 || index >= static_cast<int>(model_.accessors.size()))
      throw Error("glTF file " + file_ + ": accessor index " + std::to_string(index) + " out of range");
    return model_.accessors[static_cast<std::size_t>(index)];
  }
  View view_of(int accessor_index, std::size_t element_size) const {
    const auto& acc = accessor(accessor_index);
    if (acc.sparse.isSparse) throw Error("glTF file " + file_ + ": sparse accessors are not supported");
    if (acc.bufferView < 0 || acc.bufferView >= static_cast<int>(model_.bufferViews.size()))
      throw Error("glTF file " + file_ + ": accessor " + std::to_string(accessor_index) + " has no buffer view");
    const auto& bv = model_.bufferViews[static_cast<std::size_t>(acc.bufferView)];
    if (bv.buffer < 0 || bv.buffer >= static_cast<int>(model_.buffers.size()))
      throw Error("glTF file " + file_ + ": buffer view " + std::to_string(acc.bufferView) + " has no buffer");
    const auto& buf = model_.buffers[static_cast<std::size_t>(bv.buffer)].data;
    const std::size_t stride = bv.byteStride ? bv.byteStride : element_size;
    const std::size_t start = bv.byteOffset + acc.byteOffset;
    // In this order so that no sum or product of the file's (unbounded) sizes can wrap around.
    if (bv.byteLength > buf.size() || bv.byteOffset > buf.size() - bv.byteLength || acc.byteOffset > bv.byteLength ||
        (acc.count > 0 && (element_size > bv.byteLength - acc.byteOffset ||
                           acc.count - 1 > (bv.byteLength - acc.byteOffset - element_size) / stride)))
      throw Error("glTF file " + file_ + ": accessor " + std::to_string(accessor_index) + " reads past its buffer");
    return {buf.data() + start, stride, acc.count};
  }

  void add_primitive(const tinygltf::Primitive& prim, const Eigen::Matrix4d& world) {
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) return;
    const auto pos_it = prim.attributes.find("POSITION");
    if (pos_it == prim.attributes.end()) throw Error("glTF file " + file_ + ": a triangle primitive has no POSITION");
    const auto& pos_acc = accessor(pos_it->second);
    if (pos_acc.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT || pos_acc.type != TINYGLTF_TYPE_VEC3)
      throw Error("glTF file " + file_ + ": POSITION must be float VEC3");
    const View pos = view_of(pos_it->second, 12);
    const auto base = static_cast<int>(mesh_.vertices.size());
    for (std::size_t i = 0; i < pos.count; ++i) {
      float p[3];
      std::memcpy(p, pos.base + i * pos.stride, sizeof p);
      const Eigen::Vector4d h = world * Eigen::Vector4d(p[0], p[1], p[2], 1.0);
      mesh_.vertices.push_back(h.head<3>() / h.w());
    }

    std::vector<std::uint32_t> idx;
    if (prim.indices >= 0) {
      const auto& acc = accessor(prim.indices);
      std::size_t size = 0;
      switch (acc.componentType) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: size = 1; break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: size = 2; break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: size = 4; break;
        default: throw Error("glTF file " + file_ + ": index accessor has an unsupported component type");
      }
      const View iv = view_of(prim.indices, size);
      for (std::size_t i = 0; i < iv.count; ++i) {
        const unsigned char* p = iv.base + i * iv.stride;
        std::uint32_t v = 0;
        if (size == 1) v = p[0];
        else if (size == 2) { std::uint16_t s; std::memcpy(&s, p, 2); v = s; }
        else std::memcpy(&v, p, 4);
        if (v >= pos.count) throw Error("glTF file " + file_ + ": vertex index " + std::to_string(v) + " out of range");
        idx.push_back(v);
      }
    } else {
      for (std::size_t i = 0; i < pos.count; ++i) idx.push_back(static_cast<std::uint32_t>(i));
    }
    auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
      mesh_.triangles.emplace_back(base + static_cast<int>(a), base + static_cast<int>(b), base + static_cast<int>(c));
    };
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      for (std::size_t i = 0; i + 2 < idx.size(); i += 3) add(idx[i], idx[i + 1], idx[i + 2]);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (std::size_t i = 0; i + 2 < idx.size(); ++i)
        i % 2 == 0 ? add(idx[i], idx[i + 1], idx[i + 2]) : add(idx[i + 1], idx[i], idx[i + 2]);
    } else {
      for (std::size_t i = 1; i + 1 < idx.size(); ++i) add(idx[0], idx[i], idx[i + 1]);
    }
  }

  const tinygltf::Model& model_;
  std::string file_;
  TriangleMesh mesh_;
};

}  // namespace

TriangleMesh read_gltf_triangles(const std::filesystem::path& path) {
  const std::string file = path.string();
  if (!std::filesystem::is_regular_file(path)) throw Error("glTF file " + file + " does not exist");
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const bool ok = ext == ".glb" ? loader.LoadBinaryFromFile(&model, &err, &warn, file)
                                : loader.LoadASCIIFromFile(&model, &err, &warn, file);
  if (!ok) {
    std::string reason = err.empty() ? warn : err;
    std::replace(reason.begin(), reason.end(), '\n', ' ');
    throw Error("cannot load glTF file " + file + ": " + reason);
  }
  GltfTriangleCollector collector(model, file);
  std::vector<int> roots;
  if (!model.scenes.empty()) {
    const int s = model.defaultScene >= 0 && model.defaultScene < static_cast<int>(model.scenes.size()) ? model.defaultScene : 0;
    roots = model.scenes[static_cast<std::size_t>(s)].nodes;
  } else {
    std::vector<char> is_child(model.nodes.size(), 0);
    for (const auto& n : model.nodes)
      for (const int c : n.children)
        if (c >= 0 && c < static_cast<int>(is_child.size())) is_child[static_cast<std::size_t>(c)] = 1;
    for (std::size_t i = 0; i < model.nodes.size(); ++i)
      if (!is_child[i]) roots.push_back(static_cast<int>(i));
  }
  for (const int r : roots) collector.visit(r, Eigen::Matrix4d::Identity(), 0);
  if (roots.empty() && model.nodes.empty())  // a bare mesh list: take every mesh untransformed
    for (std::size_t m = 0; m < model.meshes.size(); ++m) collector.add_mesh(static_cast<int>(m), Eigen::Matrix4d::Identity());
  TriangleMesh mesh = collector.take();
  if (mesh.triangles.empty()) throw Error("glTF file " + file + " holds no triangles");
  return mesh;
}

}  // namespace cofusion::eval
