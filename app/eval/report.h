#pragma once
// File-level drivers behind `cofusion eval` and their output: one "key value" line per figure
// (text) or one JSON object (machine-readable). Kept out of the command so tests can run them.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "eval/object_evaluation.h"
#include "eval/reconstruction_metrics.h"
#include "eval/segmentation_metrics.h"
#include "eval/trajectory_metrics.h"

namespace cofusion::eval {

// ---- camera trajectory: ATE + RPE

struct TrajectoryEvalParams {
  AteParams ate;
  RpeParams rpe;
};

struct TrajectoryEvaluation {
  std::filesystem::path gt_file, est_file;
  AteResult ate;
  RpeParams rpe_params;
  std::optional<RpeResult> rpe;  // nullopt when RPE cannot be computed (e.g. sequence shorter than delta)
  std::string rpe_error;         // why, then
};

// ATE failures (unreadable files, no matching stamps) throw cofusion::Error naming both files;
// an RPE failure is reported in rpe_error instead, so a short sequence still gets its ATE.
TrajectoryEvaluation evaluate_trajectory_files(const std::filesystem::path& gt_file, const std::filesystem::path& est_file,
                                               const TrajectoryEvalParams& params = {});

// ---- reconstruction

struct ReconstructionEvaluation {
  std::filesystem::path model_file, gt_file;
  std::size_t points = 0, triangles = 0;
  Pose T_gt_model = Pose::Identity();  // applied to the model points before measuring
  ReconstructionErrors errors;
};

ReconstructionEvaluation evaluate_reconstruction_files(const std::filesystem::path& model_ply, const std::filesystem::path& gt_mesh,
                                                       const Pose& T_gt_model = Pose::Identity(),
                                                       const ReconstructionParams& params = {});

// "tx ty tz qx qy qz qw" (TUM order) or 16 numbers of a row-major 4x4 rigid matrix; separators may
// be spaces or commas. Throws cofusion::Error on another count or a non-rigid matrix.
Pose parse_pose_text(std::string_view text);

// The pose whose stamp is nearest to t_s; throws cofusion::Error (naming `what`) when none lies
// within max_dt_s.
Pose pose_at_time(const Trajectory& trajectory, double t_s, double max_dt_s, const std::string& what);

// ---- output

nlohmann::json to_json(const ErrorStats& stats);
nlohmann::json to_json(const TrajectoryEvaluation& evaluation);
nlohmann::json to_json(const SegmentationSummary& summary);
nlohmann::json to_json(const ReconstructionEvaluation& evaluation);
nlohmann::json to_json(const ObjectsEvaluation& evaluation);

std::string to_text(const TrajectoryEvaluation& evaluation);
std::string to_text(const SegmentationSummary& summary);
std::string to_text(const ReconstructionEvaluation& evaluation);
std::string to_text(const ObjectsEvaluation& evaluation);

}  // namespace cofusion::eval
