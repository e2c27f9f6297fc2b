#pragma once
// Every tunable parameter of the pipeline in one documented struct, loadable from a JSON file
// (`cofusion run --config FILE`). Keys mirror the struct members, grouped by stage, e.g.
//   { "preprocess": { "max_depth_m": 4.0, "bilateral": false } }
// Unknown keys and wrong types are errors naming the file and the key.
#include <filesystem>

#include "slam/dense_slam.h"

namespace cofusion::commands {

// Groups: "preprocess" (kernels::PreprocessParams), "tracker" (slam::TrackerParams), "fusion"
// (slam::FusionParams), "slam" (slam::SlamParams' own members).
struct PipelineConfig {
  slam::SlamParams slam;
};

PipelineConfig load_config(const std::filesystem::path& path);

}  // namespace cofusion::commands
