#include "eval/object_evaluation.h"

#include <Eigen/Core>
#include <algorithm>
#include <charconv>
#include <string>

#include "common/error.h"
#include "eval/assignment.h"

namespace cofusion::eval {

std::map<int, std::filesystem::path> find_id_files(const std::filesystem::path& dir, const std::string& prefix) {
  if (!std::filesystem::is_directory(dir)) throw Error("trajectory folder " + dir.string() + " does not exist");
  std::map<int, std::filesystem::path> out;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().filename().string();
    if (name.size() <= prefix.size() + 4 || name.compare(0, prefix.size(), prefix) != 0 ||
        name.compare(name.size() - 4, 4, ".txt") != 0)
      continue;
    const char* first = name.data() + prefix.size();
    const char* last = name.data() + name.size() - 4;
    int id = 0;
    const auto [ptr, ec] = std::from_chars(first, last, id);
    if (ec == std::errc() && ptr == last && id >= 0) out[id] = entry.path();
  }
  return out;
}

namespace {
// Trajectories of one side (ground truth or estimate) by id, with the files they came from.
struct IdTrajectories {
  const std::filesystem::path& dir;
  const std::map<int, std::filesystem::path>& files;
  std::map<int, Trajectory>& trajectories;
};
using PairErrors = std::map<std::pair<int, int>, ObjectTrajectoryErrors>;  // (est id, gt id)

// The pairs a given mapping names (est id -> gt id), each one's errors computed.
std::map<int, int> pairs_from_mapping(const std::map<int, int>& est_to_gt, const IdTrajectories& gt,
                                      const IdTrajectories& est, const ObjectEvaluationParams& params,
                                      PairErrors& computed) {
  std::map<int, int> pairs;
  for (const auto& [e, g] : est_to_gt) {
    if (!est.files.count(e))
      throw Error("mapping names model " + std::to_string(e) + " but " + est.dir.string() +
                  " has no model-" + std::to_string(e) + ".txt");
    if (!gt.files.count(g))
      throw Error("mapping names ground truth " + std::to_string(g) + " but " + gt.dir.string() +
                  " has no groundtruth-" + std::to_string(g) + ".txt");
    try {
      computed[{e, g}] = compute_object_trajectory_errors(gt.trajectories[g], est.trajectories[e], params.trajectory);
    } catch (const Error& err) {
      throw Error(est.files.at(e).string() + " vs " + gt.files.at(g).string() + ": " + err.what());
    }
    const int gt_id = g;  // clang 14 cannot capture a structured binding
    if (std::any_of(pairs.begin(), pairs.end(), [gt_id](const auto& p) { return p.second == gt_id; }))
      throw Error("mapping uses ground truth " + std::to_string(g) + " twice");
    pairs[e] = g;
  }
  return pairs;
}

// The one-to-one pairing of models with ground-truth objects of least summed error (tracked-point
// RMSE) among pairs with at least min_matched_poses common timestamps.
std::map<int, int> pairs_by_least_error(const IdTrajectories& gt, const IdTrajectories& est,
                                        const ObjectEvaluationParams& params, PairErrors& computed) {
  std::vector<int> est_ids, gt_ids;
  for (const auto& kv : est.files) est_ids.push_back(kv.first);
  for (const auto& kv : gt.files) gt_ids.push_back(kv.first);
  // Ineligible pairs cost more than any real error, so the matching first maximises the number
  // of eligible pairs and then minimises their summed error; ineligible picks are dropped after.
  constexpr double kIneligible = 1e6;
  Eigen::MatrixXd cost = Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(est_ids.size()),
                                                   static_cast<Eigen::Index>(gt_ids.size()), kIneligible);
  for (std::size_t i = 0; i < est_ids.size(); ++i)
    for (std::size_t j = 0; j < gt_ids.size(); ++j) {
      const Trajectory& g = gt.trajectories[gt_ids[j]];
      const Trajectory& e = est.trajectories[est_ids[i]];
      const auto matched = associate_timestamps(sorted_unique(g), sorted_unique(e), params.trajectory.association).size();
      if (matched < std::max<std::size_t>(params.min_matched_poses, 2)) continue;
      const auto errors = compute_object_trajectory_errors(g, e, params.trajectory);
      cost(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = std::min(errors.tracked_point_m.rmse, kIneligible / 2);
      computed[{est_ids[i], gt_ids[j]}] = errors;
    }
  const std::vector<int> assignment = solve_min_cost_assignment(cost);
  std::map<int, int> pairs;
  for (std::size_t i = 0; i < est_ids.size(); ++i) {
    const int j = assignment[i];
    if (j >= 0 && cost(static_cast<Eigen::Index>(i), j) < kIneligible) pairs[est_ids[i]] = gt_ids[static_cast<std::size_t>(j)];
  }
  return pairs;
}
}  // namespace

ObjectsEvaluation evaluate_object_dirs(const std::filesystem::path& gt_dir, const std::filesystem::path& est_dir,
                                       const std::optional<std::map<int, int>>& est_to_gt,
                                       const ObjectEvaluationParams& params_in) {
  const auto gt_files = find_id_files(gt_dir, "groundtruth-");
  const auto est_files = find_id_files(est_dir, "model-");
  if (gt_files.empty()) throw Error("no groundtruth-<id>.txt in " + gt_dir.string());
  if (est_files.empty()) throw Error("no model-<id>.txt in " + est_dir.string());

  std::map<int, Trajectory> gt, est;
  for (const auto& [id, path] : gt_files) gt[id] = read_tum_trajectory(path);
  for (const auto& [id, path] : est_files) est[id] = read_tum_trajectory(path);

  ObjectsEvaluation out;
  ObjectEvaluationParams params = params_in;
  // The world alignment for drift: the cameras' full poses, which every object shares (an object's
  // own path often leaves the alignment's rotation free, and so does a camera's path).
  const std::filesystem::path gt_camera = gt_dir / "groundtruth.txt", est_camera = est_dir / "camera.txt";
  if (params.trajectory.T_gt_est_world) {
    out.drift_world = "given";
  } else if (std::filesystem::is_regular_file(gt_camera) && std::filesystem::is_regular_file(est_camera)) {
    try {
      params.trajectory.T_gt_est_world =
          align_by_poses(read_tum_trajectory(gt_camera), read_tum_trajectory(est_camera), params.trajectory.association);
    } catch (const Error& err) {
      throw Error(est_camera.string() + " vs " + gt_camera.string() + " (the world alignment for drift): " + err.what());
    }
    out.drift_world = "cameras";
  }
  // The same cameras give each object's drift relative to the camera (ObjectTrajectoryErrors 5).
  if (!params.trajectory.cameras && std::filesystem::is_regular_file(gt_camera) &&
      std::filesystem::is_regular_file(est_camera))
    params.trajectory.cameras = std::make_shared<const CameraTrajectories>(
        CameraTrajectories{read_tum_trajectory(gt_camera), read_tum_trajectory(est_camera)});
  std::map<std::pair<int, int>, ObjectTrajectoryErrors> computed;
  const std::map<int, int> pairs =  // est id -> gt id
      est_to_gt ? pairs_from_mapping(*est_to_gt, {gt_dir, gt_files, gt}, {est_dir, est_files, est}, params, computed)
                : pairs_by_least_error({gt_dir, gt_files, gt}, {est_dir, est_files, est}, params, computed);

  for (const auto& [e, g] : pairs) {
    ObjectPairResult r;
    r.est_id = e;
    r.gt_id = g;
    r.est_file = est_files.at(e);
    r.gt_file = gt_files.at(g);
    r.errors = computed.at({e, g});
    out.pairs.push_back(std::move(r));
  }
  for (const auto& kv : est_files)
    if (!pairs.count(kv.first)) out.unmatched_est_ids.push_back(kv.first);
  for (const auto& kv : gt_files) {
    const bool used = std::any_of(pairs.begin(), pairs.end(), [&](const auto& p) { return p.second == kv.first; });
    if (!used) out.unmatched_gt_ids.push_back(kv.first);
  }
  return out;
}

}  // namespace cofusion::eval
