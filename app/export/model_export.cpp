#include "export/model_export.h"

#include <set>

#include "common/error.h"
#include "export/surfel_selection.h"
#include "io/atomic_file.h"

namespace cofusion {
namespace fs = std::filesystem;

std::vector<fs::path> write_models(const std::vector<SurfelCloud>& models, const Trajectory& camera,
                                   const fs::path& out_dir, const ExportOptions& options) {
  std::set<int> ids;
  for (const SurfelCloud& m : models)
    if (!ids.insert(m.model_id).second)
      throw Error("cannot export to " + out_dir.string() + ": two models have id " + std::to_string(m.model_id));

  const fs::path models_dir = out_dir / "models";
  ensure_writable_directory(models_dir);  // fail before writing anything

  const std::string gltf_ext = options.gltf_container == GltfContainer::Glb ? ".glb" : ".gltf";
  const GltfOptions gltf{.min_confidence = options.min_confidence, .container = options.gltf_container};
  const PlyOptions ply{.min_confidence = options.min_confidence, .frame = options.ply_frame};

  std::vector<fs::path> written;
  for (const SurfelCloud& model : models) {
    const fs::path stem = models_dir / model_file_stem(model);
    const fs::path gltf_path = fs::path(stem).concat(gltf_ext);
    write_model_gltf(model, gltf_path, gltf);
    written.push_back(gltf_path);
    if (options.write_ply) {
      const fs::path ply_path = fs::path(stem).concat(".ply");
      write_model_ply(model, ply_path, ply);
      written.push_back(ply_path);
    }
  }
  const fs::path scene_path = out_dir / ("scene" + gltf_ext);
  write_scene_gltf(models, camera, scene_path, gltf);
  written.push_back(scene_path);
  return written;
}

}  // namespace cofusion
