#include "export/surfel_selection.h"

#include <cmath>

#include "io/instance_classes.h"

namespace cofusion {

SurfelSelection select_surfels(const SurfelCloud& cloud, float min_confidence) {
  SurfelSelection out;
  out.surfels.reserve(cloud.surfels.size());
  for (const Surfel& s : cloud.surfels) {
    if (std::isfinite(s.confidence) && s.confidence < min_confidence) {
      ++out.below_confidence;
      continue;
    }
    const bool finite = std::isfinite(s.px) && std::isfinite(s.py) && std::isfinite(s.pz) &&
                        std::isfinite(s.nx) && std::isfinite(s.ny) && std::isfinite(s.nz) &&
                        std::isfinite(s.radius_m) && std::isfinite(s.confidence);
    const double norm = finite ? std::sqrt(double(s.nx) * s.nx + double(s.ny) * s.ny + double(s.nz) * s.nz) : 0.0;
    if (!finite || !(norm > 0.0)) {
      ++out.invalid;
      continue;
    }
    Surfel kept = s;
    kept.nx = static_cast<float>(s.nx / norm);
    kept.ny = static_cast<float>(s.ny / norm);
    kept.nz = static_cast<float>(s.nz / norm);
    out.surfels.push_back(kept);
  }
  return out;
}

std::string model_file_stem(const SurfelCloud& cloud) { return "model-" + std::to_string(cloud.model_id); }

std::string model_display_name(const SurfelCloud& cloud) {
  std::string name = model_file_stem(cloud);
  // One token, like the file stem (e.g. "teddy bear" -> "model-2-teddy_bear"); the glTF extras
  // keep the class as it is.
  return cloud.class_name.empty() ? name : name + "-" + class_name_token(cloud.class_name);
  return name;
}

}  // namespace cofusion
