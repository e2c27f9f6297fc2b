#include "export/gltf_export.h"

#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>

#include "common/error.h"
#include "export/gltf_buffer.h"
#include "export/surfel_selection.h"
#include "io/atomic_file.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {

// Accumulates buffer views, accessors, meshes and nodes of one glTF document. All data goes to
// one buffer, one tightly packed buffer view per attribute; every view starts on a 4-byte
// boundary (required for vertex attributes).
class GltfBuilder {
 public:
  GltfBuilder() {
    doc_.asset.version = "2.0";
    doc_.asset.generator = "cofusion-vk";
    doc_.scenes.emplace_back();
    doc_.defaultScene = 0;
  }

  // A node for one model; its point mesh when at least one surfel survives the selection.
  void add_model(const SurfelCloud& model, float min_confidence) {
    const std::string name = model_display_name(model);
    check_pose(model);
    const SurfelSelection selection = select_surfels(model, min_confidence);

    tinygltf::Node node;
    node.name = name;
    node.matrix = node_matrix(model.T_world_model);
    tinygltf::Value::Object info;
    info["model_id"] = tinygltf::Value(model.model_id);
    info["class_name"] = tinygltf::Value(model.class_name);
    info["state"] = tinygltf::Value(std::string(to_string(model.state)));
    tinygltf::Value::Object extras;
    extras["cofusion"] = tinygltf::Value(std::move(info));
    node.extras = tinygltf::Value(std::move(extras));
    // glTF forbids accessors with count 0 (and empty buffers), so a model with no exportable
    // surfels is a node without a mesh: the file stays valid and still names the model.
    if (!selection.surfels.empty()) node.mesh = add_points_mesh(name, selection.surfels);
    add_node(std::move(node));
  }

  void add_camera_trajectory(const std::vector<Eigen::Vector3d>& positions_world) {
    if (positions_world.size() < 2) return;  // a line needs two points
    std::vector<float> xyz;
    xyz.reserve(positions_world.size() * 3);
    for (std::size_t i = 0; i < positions_world.size(); ++i) {
      const Eigen::Vector3d& p = positions_world[i];
      if (!p.allFinite()) throw Error("camera position " + std::to_string(i) + " is not finite");
      for (int k = 0; k < 3; ++k) xyz.push_back(static_cast<float>(p[k]));
    }
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_LINE_STRIP;
    primitive.attributes["POSITION"] = add_vec3_accessor(xyz, /*with_bounds=*/true);
    tinygltf::Mesh mesh;
    mesh.name = "camera-trajectory";
    mesh.primitives.push_back(std::move(primitive));
    doc_.meshes.push_back(std::move(mesh));

    tinygltf::Node node;
    node.name = "camera-trajectory";
    node.mesh = static_cast<int>(doc_.meshes.size()) - 1;
    add_node(std::move(node));
  }

  // The finished document. With an external .bin, `bin_uri` is the buffer's file name.
  tinygltf::Model finish(const std::string& bin_uri) {
    if (!data_.empty()) {
      tinygltf::Buffer buffer;
      buffer.data = std::move(data_);
      buffer.uri = bin_uri;
      doc_.buffers.push_back(std::move(buffer));
    }
    return std::move(doc_);
  }

 private:
  static void check_pose(const SurfelCloud& model) {
    if (!model.T_world_model.matrix().allFinite())
      throw Error(model_display_name(model) + ": T_world_model is not finite");
  }

  // Column-major 4x4, empty for the identity (glTF's default). The rotation is re-orthonormalised
  // so that the validator can decompose the matrix into translation, rotation and scale even
  // when the pose carries accumulated rounding.
  static std::vector<double> node_matrix(const Eigen::Isometry3d& T_world_model) {
    if (T_world_model.matrix() == Eigen::Matrix4d::Identity()) return {};
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = Eigen::Quaterniond(T_world_model.rotation()).normalized().toRotationMatrix();
    m.topRightCorner<3, 1>() = T_world_model.translation();
    return std::vector<double>(m.data(), m.data() + 16);  // Eigen stores column-major
  }

  void add_node(tinygltf::Node node) {
    doc_.nodes.push_back(std::move(node));
    doc_.scenes[0].nodes.push_back(static_cast<int>(doc_.nodes.size()) - 1);
  }

  int add_points_mesh(const std::string& name, const std::vector<Surfel>& surfels) {
    const std::size_t n = surfels.size();
    std::vector<float> position(3 * n), normal(3 * n), radius(n), confidence(n);
    std::vector<std::uint8_t> colour(4 * n);
    for (std::size_t i = 0; i < n; ++i) {
      const Surfel& s = surfels[i];
      position[3 * i + 0] = s.px;
      position[3 * i + 1] = s.py;
      position[3 * i + 2] = s.pz;
      normal[3 * i + 0] = s.nx;
      normal[3 * i + 1] = s.ny;
      normal[3 * i + 2] = s.nz;
      radius[i] = s.radius_m;
      confidence[i] = s.confidence;
      colour[4 * i + 0] = static_cast<std::uint8_t>(s.colour_rgba8 & 0xffu);
      colour[4 * i + 1] = static_cast<std::uint8_t>((s.colour_rgba8 >> 8) & 0xffu);
      colour[4 * i + 2] = static_cast<std::uint8_t>((s.colour_rgba8 >> 16) & 0xffu);
      colour[4 * i + 3] = 255;
    }
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_POINTS;
    primitive.attributes["POSITION"] = add_vec3_accessor(position, /*with_bounds=*/true);
    primitive.attributes["NORMAL"] = add_vec3_accessor(normal, /*with_bounds=*/false);
    primitive.attributes["COLOR_0"] =
        add_accessor(colour.data(), colour.size(), TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_TYPE_VEC4, n,
                     /*normalized=*/true);
    primitive.attributes["_RADIUS"] =
        add_accessor(radius.data(), radius.size() * sizeof(float), TINYGLTF_COMPONENT_TYPE_FLOAT,
                     TINYGLTF_TYPE_SCALAR, n, false);
    primitive.attributes["_CONFIDENCE"] =
        add_accessor(confidence.data(), confidence.size() * sizeof(float), TINYGLTF_COMPONENT_TYPE_FLOAT,
                     TINYGLTF_TYPE_SCALAR, n, false);
    tinygltf::Mesh mesh;
    mesh.name = name;
    mesh.primitives.push_back(std::move(primitive));
    doc_.meshes.push_back(std::move(mesh));
    return static_cast<int>(doc_.meshes.size()) - 1;
  }

  int add_vec3_accessor(const std::vector<float>& xyz, bool with_bounds) {
    const std::size_t count = xyz.size() / 3;
    const int index = add_accessor(xyz.data(), xyz.size() * sizeof(float), TINYGLTF_COMPONENT_TYPE_FLOAT,
                                   TINYGLTF_TYPE_VEC3, count, false);
    if (with_bounds) {
      // The validator compares min/max with the stored float32 values exactly: take them from
      // the floats themselves (float -> double is exact).
      std::array<float, 3> lo, hi;
      lo.fill(std::numeric_limits<float>::infinity());
      hi.fill(-std::numeric_limits<float>::infinity());
      for (std::size_t i = 0; i < count; ++i)
        for (int k = 0; k < 3; ++k) {
          lo[k] = std::min(lo[k], xyz[3 * i + k]);
          hi[k] = std::max(hi[k], xyz[3 * i + k]);
        }
      doc_.accessors[index].minValues.assign(lo.begin(), lo.end());
      doc_.accessors[index].maxValues.assign(hi.begin(), hi.end());
    }
    return index;
  }

  int add_accessor(const void* bytes, std::size_t byte_count, int component_type, int type, std::size_t count,
                   bool normalized) {
    return gltf::append_accessor(doc_, data_, bytes, byte_count, component_type, type, count,
                                 TINYGLTF_TARGET_ARRAY_BUFFER, normalized);
  }

  tinygltf::Model doc_;
  std::vector<unsigned char> data_;
};

fs::path bin_path_for(const fs::path& gltf_path) {
  fs::path bin = gltf_path;
  bin.replace_extension(".bin");
  if (bin == gltf_path) throw Error("cannot write " + gltf_path.string() + ": a .gltf file cannot be named *.bin");
  return bin;
}

// tinygltf writes a .gltf and its .bin side by side, the .bin under the buffer's uri. To keep both
// atomic, it writes into a private staging folder beside the target; the .bin is renamed into place
// first, so a .gltf under its final name always finds its buffer.
void write_gltf_plus_bin(tinygltf::Model doc, const fs::path& path) {
  const fs::path bin_path = bin_path_for(path);
  write_atomically(path, [&](const fs::path& tmp) {
    const fs::path stage = tmp.string() + ".d";
    struct RemoveStage {
      fs::path dir;
      ~RemoveStage() {
        std::error_code ignored;
        fs::remove_all(dir, ignored);
      }
    } cleanup{stage};
    fs::create_directory(stage);
    const fs::path staged_gltf = stage / path.filename();
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToFile(&doc, staged_gltf.string(), /*embedImages=*/false, /*embedBuffers=*/false,
                                     /*prettyPrint=*/true, /*writeBinary=*/false))
      throw Error("tinygltf could not write " + staged_gltf.string());
    if (!doc.buffers.empty()) {
      const fs::path staged_bin = stage / bin_path.filename();
      // tinygltf does not report a short .bin write: compare sizes before publishing it.
      if (!fs::exists(staged_bin) || fs::file_size(staged_bin) != doc.buffers[0].data.size())
        throw Error("incomplete buffer file " + staged_bin.string() + " (disk full?)");
      write_atomically(bin_path, [&](const fs::path& tmp_bin) { fs::rename(staged_bin, tmp_bin); });
    }
    fs::rename(staged_gltf, tmp);
  });
  if (doc.buffers.empty()) {
    // No buffer now (no surfels): a .bin left by an earlier export of this model is stale.
    std::error_code ignored;
    fs::remove(bin_path, ignored);
  }
}

void write_document(GltfBuilder& builder, const fs::path& path, GltfContainer container) {
  if (container == GltfContainer::Glb) {
    gltf::write_glb(builder.finish(""), path);
  } else {
    write_gltf_plus_bin(builder.finish(bin_path_for(path).filename().string()), path);
  }
}

// Errors about the content (e.g. a non-finite pose) name the file that was being written.
template <class F>
void with_path_in_errors(const fs::path& path, F&& build) {
  try {
    build();
  } catch (const Error& e) {
    const std::string what = e.what();
    if (what.find(path.string()) != std::string::npos) throw;
    throw Error("cannot write " + path.string() + ": " + what);
  }
}

}  // namespace

void write_model_gltf(const SurfelCloud& model, const fs::path& path, const GltfOptions& options) {
  with_path_in_errors(path, [&] {
    GltfBuilder builder;
    builder.add_model(model, options.min_confidence);
    write_document(builder, path, options.container);
  });
}

void write_scene_gltf(const std::vector<SurfelCloud>& models, const std::vector<Eigen::Vector3d>& camera_positions_world,
                      const fs::path& path, const GltfOptions& options) {
  with_path_in_errors(path, [&] {
    GltfBuilder builder;
    for (const SurfelCloud& model : models) builder.add_model(model, options.min_confidence);
    builder.add_camera_trajectory(camera_positions_world);
    write_document(builder, path, options.container);
  });
}

void write_scene_gltf(const std::vector<SurfelCloud>& models, const Trajectory& camera, const fs::path& path,
                      const GltfOptions& options) {
  std::vector<Eigen::Vector3d> positions;
  positions.reserve(camera.size());
  for (const TimedPose& pose : camera) positions.push_back(pose.T_world_x.translation());
  write_scene_gltf(models, positions, path, options);
}

}  // namespace cofusion
