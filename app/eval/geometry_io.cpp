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

namespace cofusion::eval {
namespace {

// ---------------------------------------------------------------- PLY

enum class PlyFormat { ascii, binary_le, binary_be };

struct PlyProperty {
  std::string name;
  int size = 0;           // bytes of a scalar value (or of a list's items)
  char kind = 'f';        // 'i' signed, 'u' unsigned, 'f' floating
  bool is_list = false;
  int count_size = 0;     // list length type
  char count_kind = 'u';
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

bool ply_type(const std::string& t, int& size, char& kind) {
  static const struct {
    const char* name;
    int size;
    char kind;
  } types[] = {{"char", 1, 'i'},   {"int8", 1, 'i'},    {"uchar", 1, 'u'},   {"uint8", 1, 'u'},
               {"short", 2, 'i'},  {"int16", 2, 'i'},   {"ushort", 2, 'u'},  {"uint16", 2, 'u'},
               {"int", 4, 'i'},    {"int32", 4, 'i'},   {"uint", 4, 'u'},    {"uint32", 4, 'u'},
               {"float", 4, 'f'},  {"float32", 4, 'f'}, {"double", 8, 'f'},  {"float64", 8, 'f'}};
  for (const auto& t2 : types)
    if (t == t2.name) {
      size = t2.size;
      kind = t2.kind;
      return true;
    }
  return false;
}

// One binary scalar as double, honouring the file's byte order.
double decode_binary(const unsigned char* p, int size, char kind, bool big_endian) {
  unsigned char b[8];
  std::memcpy(b, p, static_cast<std::size_t>(size));
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(b, b + size);
  switch (size) {
    case 1: return kind == 'i' ? static_cast<double>(static_cast<std::int8_t>(b[0])) : static_cast<double>(b[0]);
    case 2: {
      std::uint16_t v;
      std::memcpy(&v, b, 2);
      return kind == 'i' ? static_cast<double>(static_cast<std::int16_t>(v)) : static_cast<double>(v);
    }
    case 4: {
      if (kind == 'f') {
        float f;
        std::memcpy(&f, b, 4);
        return static_cast<double>(f);
      }
      std::uint32_t v;
      std::memcpy(&v, b, 4);
      return kind == 'i' ? static_cast<double>(static_cast<std::int32_t>(v)) : static_cast<double>(v);
    }
    default: {
      double d;
      std::memcpy(&d, b, 8);
      return d;
    }
  }
}

}  // namespace

std::vector<Eigen::Vector3d> read_ply_points(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open PLY file " + file);
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());

  // Header: text lines up to "end_header".
  std::size_t pos = 0;
  auto next_line = [&](std::string& line) {
    if (pos >= data.size()) return false;
    const std::size_t nl = data.find('\n', pos);
    if (nl == std::string::npos) return false;
    line = data.substr(pos, nl - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = nl + 1;
    return true;
  };
  std::string line;
  if (!next_line(line) || line != "ply") throw Error("PLY file " + file + " does not start with 'ply'");
  PlyFormat format = PlyFormat::ascii;
  bool have_format = false, have_end = false;
  std::vector<PlyElement> elements;
  while (next_line(line)) {
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (key.empty() || key == "comment" || key == "obj_info") continue;
    if (key == "end_header") {
      have_end = true;
      break;
    }
    if (key == "format") {
      std::string f;
      ss >> f;
      if (f == "ascii") format = PlyFormat::ascii;
      else if (f == "binary_little_endian") format = PlyFormat::binary_le;
      else if (f == "binary_big_endian") format = PlyFormat::binary_be;
      else throw Error("PLY file " + file + ": unknown format '" + f + "'");
      have_format = true;
    } else if (key == "element") {
      PlyElement e;
      long long count = -1;
      ss >> e.name >> count;
      if (!ss || count < 0) throw Error("PLY file " + file + ": malformed line '" + line + "'");
      e.count = static_cast<std::size_t>(count);
      elements.push_back(e);
    } else if (key == "property") {
      if (elements.empty()) throw Error("PLY file " + file + ": property before any element");
      PlyProperty p;
      std::string type;
      ss >> type;
      if (type == "list") {
        std::string count_type, item_type;
        ss >> count_type >> item_type >> p.name;
        p.is_list = true;
        if (!ply_type(count_type, p.count_size, p.count_kind) || !ply_type(item_type, p.size, p.kind) || p.count_kind == 'f')
          throw Error("PLY file " + file + ": bad list property '" + line + "'");
      } else {
        ss >> p.name;
        if (!ply_type(type, p.size, p.kind)) throw Error("PLY file " + file + ": unknown property type '" + type + "'");
      }
      if (p.name.empty()) throw Error("PLY file " + file + ": malformed line '" + line + "'");
      elements.back().properties.push_back(p);
    } else {
      throw Error("PLY file " + file + ": unexpected header line '" + line + "'");
    }
  }
  if (!have_format || !have_end) throw Error("PLY file " + file + ": incomplete header (no format or end_header)");
  const auto vertex_it = std::find_if(elements.begin(), elements.end(), [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertex_it == elements.end()) throw Error("PLY file " + file + " has no 'vertex' element");
  int xyz_index[3] = {-1, -1, -1};
  for (std::size_t k = 0; k < vertex_it->properties.size(); ++k) {
    const auto& p = vertex_it->properties[k];
    if (p.is_list) continue;
    if (p.name == "x") xyz_index[0] = static_cast<int>(k);
    if (p.name == "y") xyz_index[1] = static_cast<int>(k);
    if (p.name == "z") xyz_index[2] = static_cast<int>(k);
  }
  if (xyz_index[0] < 0 || xyz_index[1] < 0 || xyz_index[2] < 0)
    throw Error("PLY file " + file + ": the vertex element lacks an x, y or z property");

  std::vector<Eigen::Vector3d> points;
  points.reserve(vertex_it->count);
  if (format == PlyFormat::ascii) {
    const char* cur = data.data() + pos;
    const char* const end = data.data() + data.size();
    auto next_number = [&](const std::string& element, std::size_t instance) {
      while (cur < end && std::isspace(static_cast<unsigned char>(*cur))) ++cur;
      double v = 0;
      const auto [ptr, ec] = std::from_chars(cur, end, v);
      if (ec != std::errc() || ptr == cur)
        throw Error("PLY file " + file + ": " + element + " " + std::to_string(instance) + ": expected a number");
      cur = ptr;
      return v;
    };
    for (const auto& e : elements) {
      const bool is_vertex = &e == &*vertex_it;
      for (std::size_t n = 0; n < e.count; ++n) {
        Eigen::Vector3d xyz;
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
          const auto& p = e.properties[k];
          if (p.is_list) {
            const double len = next_number(e.name, n);
            if (len < 0 || len != std::floor(len))
              throw Error("PLY file " + file + ": " + e.name + " " + std::to_string(n) + ": bad list length");
            for (long long m = 0; m < static_cast<long long>(len); ++m) next_number(e.name, n);
            continue;
          }
          const double v = next_number(e.name, n);
          for (int c = 0; c < 3; ++c)
            if (static_cast<int>(k) == xyz_index[c]) xyz[c] = v;
        }
        if (is_vertex) points.push_back(xyz);
      }
      if (is_vertex) break;  // later elements are not needed
    }
  } else {
    const bool big_endian = format == PlyFormat::binary_be;
    const auto* bytes = reinterpret_cast<const unsigned char*>(data.data());
    std::size_t at = pos;
    auto need = [&](std::size_t n, const std::string& element, std::size_t instance) {
      if (data.size() - at < n)
        throw Error("PLY file " + file + " is truncated at " + element + " " + std::to_string(instance));
    };
    for (const auto& e : elements) {
      const bool is_vertex = &e == &*vertex_it;
      for (std::size_t n = 0; n < e.count; ++n) {
        Eigen::Vector3d xyz;
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
          const auto& p = e.properties[k];
          if (p.is_list) {
            need(static_cast<std::size_t>(p.count_size), e.name, n);
            const double len = decode_binary(bytes + at, p.count_size, p.count_kind, big_endian);
            at += static_cast<std::size_t>(p.count_size);
            if (len < 0) throw Error("PLY file " + file + ": " + e.name + " " + std::to_string(n) + ": negative list length");
            const std::size_t list_bytes = static_cast<std::size_t>(len) * static_cast<std::size_t>(p.size);
            need(list_bytes, e.name, n);
            at += list_bytes;
            continue;
          }
          need(static_cast<std::size_t>(p.size), e.name, n);
          if (is_vertex)
            for (int c = 0; c < 3; ++c)
              if (static_cast<int>(k) == xyz_index[c]) xyz[c] = decode_binary(bytes + at, p.size, p.kind, big_endian);
          at += static_cast<std::size_t>(p.size);
        }
        if (is_vertex) points.push_back(xyz);
      }
      if (is_vertex) break;
    }
  }
  for (std::size_t n = 0; n < points.size(); ++n)
    if (!points[n].allFinite()) throw Error("PLY file " + file + ": vertex " + std::to_string(n) + " has a non-finite coordinate");
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
  View view_of(int accessor_index, std::size_t element_size) const {
    if (accessor_index < 0 || accessor_index >= static_cast<int>(model_.accessors.size()))
      throw Error("glTF file " + file_ + ": accessor index " + std::to_string(accessor_index) + " out of range");
    const auto& acc = model_.accessors[static_cast<std::size_t>(accessor_index)];
    if (acc.sparse.isSparse) throw Error("glTF file " + file_ + ": sparse accessors are not supported");
    if (acc.bufferView < 0 || acc.bufferView >= static_cast<int>(model_.bufferViews.size()))
      throw Error("glTF file " + file_ + ": accessor " + std::to_string(accessor_index) + " has no buffer view");
    const auto& bv = model_.bufferViews[static_cast<std::size_t>(acc.bufferView)];
    if (bv.buffer < 0 || bv.buffer >= static_cast<int>(model_.buffers.size()))
      throw Error("glTF file " + file_ + ": buffer view " + std::to_string(acc.bufferView) + " has no buffer");
    const auto& buf = model_.buffers[static_cast<std::size_t>(bv.buffer)].data;
    const std::size_t stride = bv.byteStride ? bv.byteStride : element_size;
    const std::size_t start = bv.byteOffset + acc.byteOffset;
    const std::size_t needed = acc.count == 0 ? 0 : stride * (acc.count - 1) + element_size;
    if (acc.byteOffset + needed > bv.byteLength || bv.byteOffset + bv.byteLength > buf.size())
      throw Error("glTF file " + file_ + ": accessor " + std::to_string(accessor_index) + " reads past its buffer");
    return {buf.data() + start, stride, acc.count};
  }

  void add_primitive(const tinygltf::Primitive& prim, const Eigen::Matrix4d& world) {
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) return;
    const auto pos_it = prim.attributes.find("POSITION");
    if (pos_it == prim.attributes.end()) throw Error("glTF file " + file_ + ": a triangle primitive has no POSITION");
    const auto& pos_acc = model_.accessors.at(static_cast<std::size_t>(std::max(0, pos_it->second)));
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
      const auto& acc = model_.accessors.at(static_cast<std::size_t>(prim.indices));
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
