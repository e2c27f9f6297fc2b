#pragma once
// Which surfels of a model leave the program, shared by the glTF and PLY writers so that a model's
// .glb and .ply hold the same points in the same order.
#include <cstddef>
#include <string>
#include <vector>

#include "common/surfel_cloud.h"

namespace cofusion {

struct SurfelSelection {
  std::vector<Surfel> surfels;       // kept surfels, normals renormalised to unit length
  std::size_t below_confidence = 0;  // left out: confidence < min_confidence
  std::size_t invalid = 0;           // left out: non-finite field or zero normal (cannot be exported
                                     // as a glTF NORMAL, which must be unit length)
};

// Keeps surfels with confidence >= min_confidence (fusion weight, unitless; 0 keeps all, since
// confidence is never negative) whose position, normal, radius and confidence are finite and
// whose normal is non-zero. Normals are renormalised in double precision.
SurfelSelection select_surfels(const SurfelCloud& cloud, float min_confidence);

// "model-<id>": the file stem of a model's files and the start of its glTF node name.
std::string model_file_stem(const SurfelCloud& cloud);
// The glTF node name: "model-<id>-<class>", e.g. "model-3-cup" (spaces in the class become '_'),
// or "model-<id>" when the class is unknown (empty).
std::string model_display_name(const SurfelCloud& cloud);

}  // namespace cofusion
