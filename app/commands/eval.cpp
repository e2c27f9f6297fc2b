// `cofusion eval`: trajectory, segmentation, reconstruction and per-object metrics.
//   cofusion eval --gt groundtruth.txt --est trajectory.txt       ATE + RPE of a camera trajectory
//   cofusion eval seg --gt-masks DIR --est-masks DIR               per-label IoU per frame
//   cofusion eval recon --model model.ply --gt scene.glb           surfel-to-mesh distances
//   cofusion eval objects --gt-dir DIR --est-dir DIR               ATE of every object model
//   cofusion eval map --model model.ply                            duplicate and unconfirmed surfels
// Every form prints "key value" lines, or one JSON object with --json. The metrics live in
// app/eval (see report.h); this file only wires options to them.
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands/commands.h"
#include "common/error.h"
#include "eval/drift_plot.h"
#include "eval/report.h"
#include "eval/surfel_map_metrics.h"

namespace cofusion::commands {
namespace {

void print(const nlohmann::json& j, const std::string& text, bool json) {
  const std::string out = json ? j.dump(2) + "\n" : text;
  std::fputs(out.c_str(), stdout);
  std::fflush(stdout);
}

struct TrajectoryOptions {
  std::string gt, est;
  double rpe_delta = 1.0;
  std::string rpe_unit = "s";
  double max_dt_s = 0.02;
  bool json = false;
};

struct SegOptions {
  std::string gt_dir, est_dir;
  int gt_ignore = 0xFFFF;
  int est_unlabelled = 0xFFFF;
  bool json = false;
};

struct ReconOptions {
  std::string model, gt;
  std::string transform;
  std::string gt_poses;
  double gt_pose_time_s = 0;
  double max_dt_s = 0.02;
  std::vector<double> thresholds_m = {0.01, 0.05};
  bool json = false;
};

struct ObjectOptions {
  std::string gt_dir, est_dir;
  std::vector<std::string> map;
  double max_dt_s = 0.02;
  std::size_t min_poses = 10;
  bool json = false;
  std::string plot_dir;  // drift charts, one PNG per matched model (empty: none)
};

void run_trajectory(const TrajectoryOptions& o) {
  if (o.gt.empty() || o.est.empty())
    throw Error("eval: give --gt and --est (trajectories), or one of the subcommands seg, recon, objects");
  eval::TrajectoryEvalParams params;
  params.ate.association.max_difference_s = o.max_dt_s;
  params.rpe.delta = o.rpe_delta;
  params.rpe.unit = o.rpe_unit == "s" ? eval::RpeDeltaUnit::seconds : eval::RpeDeltaUnit::frames;
  const auto result = eval::evaluate_trajectory_files(o.gt, o.est, params);
  print(eval::to_json(result), eval::to_text(result), o.json);
}

void run_seg(const SegOptions& o) {
  eval::SegmentationParams params;
  params.gt_ignore_label = static_cast<std::uint16_t>(o.gt_ignore);
  params.est_unlabelled = static_cast<std::uint16_t>(o.est_unlabelled);
  const auto result = eval::evaluate_segmentation_dirs(o.gt_dir, o.est_dir, params);
  print(eval::to_json(result), eval::to_text(result), o.json);
}

void run_recon(const ReconOptions& o) {
  Pose T_gt_model = Pose::Identity();
  if (!o.transform.empty()) T_gt_model = eval::parse_pose_text(o.transform);
  if (!o.gt_poses.empty()) {
    // The model frame is the world frame at the model's first frame; the mesh is in the object's
    // own frame, so T_object_model = T_world_object(first frame)^-1.
    const Pose T_world_object =
        eval::pose_at_time(read_tum_trajectory(o.gt_poses), o.gt_pose_time_s, o.max_dt_s, o.gt_poses);
    T_gt_model = T_world_object.inverse();
  }
  eval::ReconstructionParams params;
  params.outlier_thresholds_m = o.thresholds_m;
  const auto result = eval::evaluate_reconstruction_files(o.model, o.gt, T_gt_model, params);
  print(eval::to_json(result), eval::to_text(result), o.json);
}

struct MapOptions {
  std::vector<std::string> models;
  eval::DuplicateParams params;
  bool json = false;
};

void run_map(const MapOptions& o) {
  nlohmann::json j = nlohmann::json::array();
  std::string text;
  for (const auto& path : o.models) {
    const auto stats = eval::compute_surfel_map_stats(eval::read_ply_surfels(path), o.params);
    j.push_back({{"model", path},
                 {"surfels", stats.surfels},
                 {"duplicates", stats.duplicates},
                 {"duplicate_share", stats.duplicate_share},
                 {"low_confidence_share", stats.low_confidence_share}});
    char line[512];
    std::snprintf(line, sizeof line, "model %s\nsurfels %zu\nduplicate_share %.4f\nlow_confidence_share %.4f\n",
                  path.c_str(), stats.surfels, stats.duplicate_share, stats.low_confidence_share);
    text += line;
  }
  print(o.models.size() == 1 ? j[0] : j, text, o.json);
}

void run_objects(const ObjectOptions& o) {
  std::optional<std::map<int, int>> mapping;
  if (!o.map.empty()) {
    mapping.emplace();
    for (const auto& entry : o.map) {
      int model_id = 0, gt_id = 0;
      char extra = 0;
      if (std::sscanf(entry.c_str(), "%d:%d%c", &model_id, &gt_id, &extra) != 2 || model_id < 0 || gt_id < 0)
        throw Error("eval objects: --map entry '" + entry + "' is not MODEL_ID:GT_ID");
      if (!mapping->emplace(model_id, gt_id).second)
        throw Error("eval objects: --map names model " + std::to_string(model_id) + " twice");
    }
  }
  eval::ObjectEvaluationParams params;
  params.trajectory.association.max_difference_s = o.max_dt_s;
  params.min_matched_poses = o.min_poses;
  const auto result = eval::evaluate_object_dirs(o.gt_dir, o.est_dir, mapping, params);
  if (!o.plot_dir.empty()) eval::write_drift_plots(result, o.plot_dir);
  print(eval::to_json(result), eval::to_text(result), o.json);
}

}  // namespace

void add_eval(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "eval", "Evaluate results against ground truth: camera trajectory (ATE, RPE as the TUM benchmark scripts), or a "
              "subcommand: seg, recon, objects, map");
  cmd->require_subcommand(0, 1);

  auto traj = std::make_shared<TrajectoryOptions>();
  cmd->add_option("--gt", traj->gt, "Ground-truth trajectory (TUM format: t tx ty tz qx qy qz qw)");
  cmd->add_option("--est", traj->est, "Estimated trajectory (TUM format)");
  cmd->add_option("--rpe-delta", traj->rpe_delta, "RPE: distance between compared poses")->capture_default_str();
  cmd->add_option("--rpe-unit", traj->rpe_unit, "RPE: unit of --rpe-delta")
      ->check(CLI::IsMember({"s", "frames"}))
      ->capture_default_str();
  cmd->add_option("--max-dt", traj->max_dt_s, "ATE: largest timestamp difference of a matched pair (s)")->capture_default_str();
  cmd->add_flag("--json", traj->json, "Print one JSON object instead of key-value lines");
  cmd->callback([cmd, traj] {
    if (!cmd->get_subcommands().empty()) return;  // a subcommand did the work
    run_trajectory(*traj);
  });

  auto seg = std::make_shared<SegOptions>();
  auto* seg_cmd = cmd->add_subcommand("seg", "Per-label intersection-over-union of label images (matched per frame)");
  seg_cmd->add_option("--gt-masks", seg->gt_dir, "Folder of ground-truth instance images (16-bit PNG)")->required();
  seg_cmd->add_option("--est-masks", seg->est_dir, "Folder of estimated label images with the same file names")->required();
  seg_cmd->add_option("--gt-ignore", seg->gt_ignore, "Ground-truth value of pixels to leave out")
      ->check(CLI::Range(0, 0xFFFF))
      ->capture_default_str();
  seg_cmd->add_option("--est-unlabelled", seg->est_unlabelled, "Estimated value meaning 'no label'")
      ->check(CLI::Range(0, 0xFFFF))
      ->capture_default_str();
  seg_cmd->add_flag("--json", seg->json, "Print one JSON object");
  seg_cmd->callback([seg] { run_seg(*seg); });

  auto recon = std::make_shared<ReconOptions>();
  auto* recon_cmd = cmd->add_subcommand("recon", "Distance of every model point to the ground-truth meshes (paper Table I)");
  recon_cmd->add_option("--model", recon->model, "Model points (PLY with x, y, z vertex properties)")->required();
  recon_cmd->add_option("--gt", recon->gt, "Ground-truth geometry (glTF 2.0: .glb or .gltf)")->required();
  auto* transform = recon_cmd->add_option(
      "--transform", recon->transform, "Rigid transform applied to the model points first: 'tx ty tz qx qy qz qw' or 16 numbers (4x4 row-major)");
  auto* gt_poses = recon_cmd->add_option(
      "--gt-poses", recon->gt_poses, "Ground-truth object trajectory (TUM): map points by the inverse of its pose at --gt-pose-time");
  gt_poses->excludes(transform);
  auto* gt_pose_time =
      recon_cmd->add_option("--gt-pose-time", recon->gt_pose_time_s, "Time (s) of the model's first frame, for --gt-poses");
  gt_pose_time->needs(gt_poses);
  gt_poses->needs(gt_pose_time);
  recon_cmd->add_option("--max-dt", recon->max_dt_s, "Largest time difference to the pose used (s)")->capture_default_str();
  recon_cmd->add_option("--thresholds", recon->thresholds_m, "Outlier distances (m)")->delimiter(',')->capture_default_str();
  recon_cmd->add_flag("--json", recon->json, "Print one JSON object");
  recon_cmd->callback([recon] { run_recon(*recon); });

  auto objects = std::make_shared<ObjectOptions>();
  auto* objects_cmd = cmd->add_subcommand("objects", "ATE of every object: groundtruth-<id>.txt vs model-<id>.txt");
  objects_cmd->add_option("--gt-dir", objects->gt_dir, "Folder of groundtruth-<id>.txt (T_world_object)")->required();
  objects_cmd->add_option("--est-dir", objects->est_dir, "Folder of model-<id>.txt (T_world_model)")->required();
  objects_cmd->add_option("--map", objects->map, "Fixed pairs MODEL_ID:GT_ID (default: matched by smallest ATE)")->delimiter(',');
  objects_cmd->add_option("--max-dt", objects->max_dt_s, "Largest timestamp difference of a matched pair (s)")->capture_default_str();
  objects_cmd->add_option("--min-poses", objects->min_poses, "Automatic matching: fewest matched stamps for a candidate pair")
      ->capture_default_str();
  objects_cmd->add_flag("--json", objects->json, "Print one JSON object");
  objects_cmd->add_option("--plot", objects->plot_dir,
                          "Write DIR/drift-model-<id>.png: each model's drift since first seen against time");
  objects_cmd->callback([objects] { run_objects(*objects); });

  auto map = std::make_shared<MapOptions>();
  auto* map_cmd = cmd->add_subcommand(
      "map", "Redundancy of surfel models: share of surfels with another within a fraction of their radius and a "
             "similar normal (duplicates), and share below a confidence (unconfirmed)");
  map_cmd->add_option("--model", map->models, "Model PLY files as cofusion run writes them (models/model-<id>.ply)")
      ->required();
  map_cmd->add_option("--radius-fraction", map->params.radius_fraction, "Duplicate: neighbour within this fraction of the radius")
      ->capture_default_str();
  map_cmd->add_option("--max-normal-angle", map->params.max_normal_angle_deg, "Duplicate: normals within this angle (degrees)")
      ->capture_default_str();
  map_cmd->add_option("--low-confidence", map->params.low_confidence, "Unconfirmed: confidence below this")
      ->capture_default_str();
  map_cmd->add_flag("--json", map->json, "Print one JSON object (an array for several models)");
  map_cmd->callback([map] { run_map(*map); });
}

}  // namespace cofusion::commands
