#pragma once
// Every tunable parameter of the pipeline in one documented struct, loadable from a JSON file
// (`cofusion run --config FILE`). Keys mirror the struct members, grouped by stage, e.g.
//   { "preprocess": { "max_depth_m": 4.0, "bilateral": false } }
// Unknown keys and wrong types are errors naming the file and the key.
#include <filesystem>

#include "slam/co_fusion.h"

namespace cofusion::commands {

// Groups: "preprocess" (kernels::PreprocessParams), "tracker" (slam::TrackerParams), "fusion"
// (slam::FusionParams), "slam" (slam::SlamParams' own members), "segmentation"
// (segmentation::MotionSegmentationParams, SLIC under "segmentation": {"slic": {...}}), "costs"
// (slam::MotionCostParams), "lifecycle" (slam::LifecycleParams), "rolling_shutter"
// (slam::SlamParams::rolling_shutter), "motion_segmentation" (bool).
struct PipelineConfig {
  slam::SlamParams slam;
  segmentation::MotionSegmentationParams segmentation;
  slam::MotionCostParams costs;
  slam::LifecycleParams lifecycle;
  slam::RestParams rest;
  slam::CameraCheckParams camera_check;
  slam::CameraRetrackParams retrack;
  slam::SemanticParams semantic;  // thresholds only: mode and classes come from the command line
  bool motion_segmentation = true;

  // By name: an aggregate initialiser in member order silently put motion_segmentation into
  // relocalisation.keyframes.cols once CoFusionParams grew a member before it.
  slam::CoFusionParams cofusion() const {
    slam::CoFusionParams p;
    p.slam = slam;
    p.segmentation = segmentation;
    p.costs = costs;
    p.lifecycle = lifecycle;
    p.rest = rest;
    p.camera_check = camera_check;
    p.retrack = retrack;
    p.semantic = semantic;
    p.motion_segmentation = motion_segmentation;
    return p;
  }
};

PipelineConfig load_config(const std::filesystem::path& path);

}  // namespace cofusion::commands
