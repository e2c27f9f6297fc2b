#include "synthetic/gltf_export.h"

#include <tiny_gltf.h>

#include <cstring>

#include "common/error.h"
#include "export/gltf_buffer.h"

namespace cofusion::synthetic {
namespace {

// Appends raw bytes to the single buffer with a buffer view + accessor for them.
int add_accessor(tinygltf::Model& model, const void* data, size_t bytes, size_t count, int component_type, int type,
                 int target, const std::vector<double>& min = {}, const std::vector<double>& max = {}) {
  const int index = gltf::append_accessor(model, model.buffers[0].data, data, bytes, component_type, type, count, target);
  model.accessors[size_t(index)].minValues = min;
  model.accessors[size_t(index)].maxValues = max;
  return index;
}

std::vector<float> flatten(const std::vector<Eigen::Vector3f>& v) {
  std::vector<float> out;
  out.reserve(v.size() * 3);
  for (const auto& x : v) out.insert(out.end(), {x.x(), x.y(), x.z()});
  return out;
}

template <typename T>
void read_accessor(const tinygltf::Model& model, int index, int want_type, int want_components,
                   std::vector<T>& out, const std::filesystem::path& path) {
  if (index < 0 || index >= static_cast<int>(model.accessors.size())) throw Error(path.string() + ": bad accessor");
  const auto& acc = model.accessors[index];
  if (acc.type != want_type || acc.componentType != want_components || acc.bufferView < 0)
    throw Error(path.string() + ": unexpected accessor layout");
  const auto& view = model.bufferViews.at(acc.bufferView);
  const auto& buf = model.buffers.at(view.buffer).data;
  const size_t n = acc.count * static_cast<size_t>(tinygltf::GetNumComponentsInType(static_cast<uint32_t>(acc.type)));
  const size_t begin = view.byteOffset + acc.byteOffset;
  if ((view.byteStride != 0 && view.byteStride != n / acc.count * sizeof(T)) || begin + n * sizeof(T) > buf.size())
    throw Error(path.string() + ": accessor out of range or interleaved");
  out.resize(n);
  if (n) std::memcpy(out.data(), buf.data() + begin, n * sizeof(T));
}

}  // namespace

void write_glb(const Mesh& mesh, const std::string& name, const std::filesystem::path& path) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "cofusion-vk synthetic scene generator";
  model.buffers.resize(1);

  Eigen::Vector3f lo = Eigen::Vector3f::Zero(), hi = Eigen::Vector3f::Zero();
  if (!mesh.positions.empty()) {
    lo = hi = mesh.positions[0];
    for (const auto& p : mesh.positions) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  tinygltf::Scene scene;
  if (mesh.positions.empty() || mesh.indices.empty()) {  // glTF forbids empty accessors: a scene without nodes
    model.scenes.push_back(scene);
    model.defaultScene = 0;
    model.buffers.clear();
    gltf::write_glb(model, path);
    return;
  }
  const auto positions = flatten(mesh.positions), normals = flatten(mesh.normals), colors = flatten(mesh.colors);
  const size_t n = mesh.positions.size();
  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.attributes["POSITION"] =
      add_accessor(model, positions.data(), positions.size() * sizeof(float), n, TINYGLTF_COMPONENT_TYPE_FLOAT,
                   TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER, {lo.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), hi.z()});
  prim.attributes["NORMAL"] = add_accessor(model, normals.data(), normals.size() * sizeof(float), n,
                                           TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER);
  prim.attributes["COLOR_0"] = add_accessor(model, colors.data(), colors.size() * sizeof(float), n,
                                            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, TINYGLTF_TARGET_ARRAY_BUFFER);
  prim.indices = add_accessor(model, mesh.indices.data(), mesh.indices.size() * sizeof(uint32_t), mesh.indices.size(),
                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR,
                              TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  prim.material = 0;
  tinygltf::Material material;  // plain white, so the vertex colours show as they are
  material.name = name;
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 1.0;
  model.materials.push_back(material);
  tinygltf::Mesh gltf_mesh;
  gltf_mesh.name = name;
  gltf_mesh.primitives.push_back(prim);
  model.meshes.push_back(gltf_mesh);
  tinygltf::Node node;
  node.mesh = 0;
  node.name = name;
  model.nodes.push_back(node);
  scene.nodes.push_back(0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  gltf::write_glb(model, path);
}

Mesh read_glb(const std::filesystem::path& path) {
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  if (!loader.LoadBinaryFromFile(&model, &err, &warn, path.string()))
    throw Error(path.string() + ": cannot read glTF binary: " + err);
  if (model.meshes.empty() || model.meshes[0].primitives.empty()) throw Error(path.string() + ": no mesh");
  const auto& prim = model.meshes[0].primitives[0];
  if (prim.mode != TINYGLTF_MODE_TRIANGLES) throw Error(path.string() + ": not a triangle mesh");
  auto attribute = [&](const char* key) {
    const auto it = prim.attributes.find(key);
    if (it == prim.attributes.end()) throw Error(path.string() + ": no " + key + " attribute");
    return it->second;
  };
  std::vector<float> positions, normals, colors;
  read_accessor(model, attribute("POSITION"), TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, positions, path);
  read_accessor(model, attribute("NORMAL"), TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, normals, path);
  read_accessor(model, attribute("COLOR_0"), TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, colors, path);
  Mesh mesh;
  read_accessor(model, prim.indices, TINYGLTF_TYPE_SCALAR, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, mesh.indices, path);
  if (normals.size() != positions.size() || colors.size() != positions.size())
    throw Error(path.string() + ": attribute counts differ");
  const size_t n = positions.size() / 3;
  for (size_t i = 0; i < n; ++i) {
    mesh.positions.emplace_back(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]);
    mesh.normals.emplace_back(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]);
    mesh.colors.emplace_back(colors[3 * i], colors[3 * i + 1], colors[3 * i + 2]);
  }
  for (uint32_t idx : mesh.indices)
    if (idx >= n) throw Error(path.string() + ": index out of range");
  return mesh;
}

}  // namespace cofusion::synthetic
