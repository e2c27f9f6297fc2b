#pragma once
// Writes a run's models into an output folder:
//   <out_dir>/models/model-<id>.glb   one glTF point cloud per model (gltf_export.h)
//   <out_dir>/models/model-<id>.ply   the same surfels as PLY (ply_export.h)
//   <out_dir>/scene.glb               every model at its last pose plus the camera trajectory
// With GltfContainer::GltfPlusBin the glTF files are .gltf with a .bin beside each.
// Files of models exported earlier into the same folder but absent now are left alone.
#include <filesystem>
#include <vector>

#include "common/surfel_cloud.h"
#include "export/gltf_export.h"
#include "export/ply_export.h"
#include "io/trajectory.h"

namespace cofusion {

struct ExportOptions {
  // Surfels with confidence below this (fusion weight, unitless) are left out of every file.
  // 0 keeps all (confidence is never negative).
  float min_confidence = 0.0f;
  GltfContainer gltf_container = GltfContainer::Glb;
  PlyFrame ply_frame = PlyFrame::Model;  // model frame matches the glTF vertices
  bool write_ply = true;                 // false: glTF files only
};

// Writes every model given (callers choose which, e.g. leave out deleted ones) and the scene.
// camera holds T_world_camera per frame. Returns the paths written, the scene last (the .bin
// beside each .gltf is not listed). Throws
// cofusion::Error naming the folder or file when it cannot be written, or when two models share an
// id (their files would overwrite each other).
std::vector<std::filesystem::path> write_models(const std::vector<SurfelCloud>& models, const Trajectory& camera,
                                                const std::filesystem::path& out_dir,
                                                const ExportOptions& options = {});

}  // namespace cofusion
