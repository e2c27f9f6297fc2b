#pragma once
// Per-object trajectory evaluation over folders: ground truth groundtruth-<id>.txt (T_world_object)
// against the system's model-<id>.txt (T_world_model), both TUM format. Model ids and ground-truth
// ids are unrelated numbers, so pairs come from a given mapping or from an optimal one-to-one
// matching that minimises the tracked-point ATE (see trajectory_metrics.h).
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "eval/trajectory_metrics.h"

namespace cofusion::eval {

struct ObjectEvaluationParams {
  ObjectTrajectoryParams trajectory;
  // Automatic matching only considers pairs with at least this many matched stamps: with very
  // few, the tracked-point fit (9 parameters) explains any trajectory.
  std::size_t min_matched_poses = 10;
};

struct ObjectPairResult {
  int est_id = 0;
  int gt_id = 0;
  std::filesystem::path est_file, gt_file;
  ObjectTrajectoryErrors errors;
};

struct ObjectsEvaluation {
  std::vector<ObjectPairResult> pairs;  // ascending est_id
  // Where drift is measured: "cameras" (align_by_poses of est_dir/camera.txt to
  // gt_dir/groundtruth.txt, when both exist), "given" or "tracked point" (each pair's own fit).
  std::string drift_world = "tracked point";
  std::vector<int> unmatched_est_ids;
  std::vector<int> unmatched_gt_ids;
};

// <prefix><id>.txt files in `dir`, by id. Throws cofusion::Error when `dir` is not a folder.
std::map<int, std::filesystem::path> find_id_files(const std::filesystem::path& dir, const std::string& prefix);

// `est_to_gt`: a fixed mapping model id -> ground-truth id (files must exist), or nullopt for the
// automatic matching. When gt_dir/groundtruth.txt (the camera) and est_dir/camera.txt both exist,
// drift is measured in their pose alignment (unless params.trajectory.T_gt_est_world is given). Throws cofusion::Error naming the files on unreadable trajectories, when
// a folder holds no files, or (fixed mapping) when a mapped pair cannot be evaluated.
ObjectsEvaluation evaluate_object_dirs(const std::filesystem::path& gt_dir, const std::filesystem::path& est_dir,
                                       const std::optional<std::map<int, int>>& est_to_gt,
                                       const ObjectEvaluationParams& params = {});

}  // namespace cofusion::eval
