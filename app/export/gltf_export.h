#pragma once
// Surfel models as glTF 2.0 point clouds, for any glTF viewer (Blender, three.js, gltf.report).
//
// Each model is one mesh with one POINTS primitive:
//   POSITION     float VEC3, model frame, metres (accessor min/max set)
//   NORMAL       float VEC3, model frame, unit length
//   COLOR_0      normalized unsigned byte VEC4: the surfel's R, G, B, alpha always 255 (surfels
//                are opaque; the alpha byte of colour_rgba8 carries no transparency)
//   _RADIUS      float SCALAR, disc radius in metres
//   _CONFIDENCE  float SCALAR, fusion weight
// The vertices stay in the model's own frame and the node's `matrix` is T_world_model (column
// major), so a viewer shows the scene as last seen and a tool can still read model-frame points.
// An identity pose is written as no matrix (glTF's default; the validator flags an explicit one).
// Node `extras.cofusion` holds model_id, class_name and state.
//
// Only surfels selected by select_surfels() are written (confidence threshold, finite values,
// non-zero normals). Files are written atomically: nothing appears under the final name unless the
// whole file was written.
#include <Eigen/Core>
#include <filesystem>
#include <vector>

#include "common/surfel_cloud.h"
#include "io/trajectory.h"

namespace cofusion {

enum class GltfContainer {
  Glb,          // one binary .glb file (default)
  GltfPlusBin,  // JSON .gltf plus a .bin beside it with the same stem
};

struct GltfOptions {
  // Surfels with confidence below this (fusion weight, unitless) are left out. 0 keeps all.
  float min_confidence = 0.0f;
  GltfContainer container = GltfContainer::Glb;
};

// One model in its own file: a node named model_display_name() (with the pose as matrix) and its
// point mesh. A model with no exportable surfels gives a valid file with a node and no mesh.
// With GltfPlusBin the buffer goes to path.replace_extension(".bin").
// Throws cofusion::Error naming the path when it cannot be written or the pose is not finite.
void write_model_gltf(const SurfelCloud& model, const std::filesystem::path& path,
                      const GltfOptions& options = {});

// Every model as a node (as in write_model_gltf) plus the camera path as a LINE_STRIP mesh node
// named "camera-trajectory" in world coordinates (left out with fewer than 2 positions).
void write_scene_gltf(const std::vector<SurfelCloud>& models,
                      const std::vector<Eigen::Vector3d>& camera_positions_world,
                      const std::filesystem::path& path, const GltfOptions& options = {});
// Same, with the camera positions taken from T_world_camera of each trajectory pose.
void write_scene_gltf(const std::vector<SurfelCloud>& models, const Trajectory& camera,
                      const std::filesystem::path& path, const GltfOptions& options = {});

}  // namespace cofusion
