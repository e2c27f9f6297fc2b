#pragma once
// A model's surfels on the host, as exported to glTF/PLY or shown by the viewer: a copy read
// back from the model's GPU buffer, plus the model's identity and last pose.
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "shared/host_device.h"

namespace cofusion {

using Surfel = gpu_layout::Surfel;

enum class ModelState { Active, Inactive, Deleted };

inline const char* to_string(ModelState s) {
  switch (s) {
    case ModelState::Active: return "active";
    case ModelState::Inactive: return "inactive";
    default: return "deleted";
  }
}

struct SurfelCloud {
  int model_id = 0;                 // 0 = the background / camera model
  std::string class_name;           // semantic class when known, else empty
  ModelState state = ModelState::Active;
  Eigen::Isometry3d T_world_model = Eigen::Isometry3d::Identity();  // pose when last seen
  std::vector<Surfel> surfels;      // in the model's own frame
};

}  // namespace cofusion
