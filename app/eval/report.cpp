#include "eval/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "common/error.h"

namespace cofusion::eval {
namespace {

std::string line(const std::string& key, double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, " %.6f\n", value);  // the TUM scripts' %f
  return key + buf;
}

std::string line(const std::string& key, std::size_t value) { return key + " " + std::to_string(value) + "\n"; }

std::string stats_lines(const std::string& prefix, const std::string& unit, const ErrorStats& s) {
  std::string out;
  out += line(prefix + "_rmse_" + unit, s.rmse);
  out += line(prefix + "_mean_" + unit, s.mean);
  out += line(prefix + "_median_" + unit, s.median);
  out += line(prefix + "_std_" + unit, s.std);
  out += line(prefix + "_min_" + unit, s.min);
  out += line(prefix + "_max_" + unit, s.max);
  return out;
}

std::string threshold_key(double threshold_m) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", threshold_m);
  return buf;
}

}  // namespace

TrajectoryEvaluation evaluate_trajectory_files(const std::filesystem::path& gt_file, const std::filesystem::path& est_file,
                                               const TrajectoryEvalParams& params) {
  TrajectoryEvaluation out;
  out.gt_file = gt_file;
  out.est_file = est_file;
  out.rpe_params = params.rpe;
  const Trajectory gt = read_tum_trajectory(gt_file);
  const Trajectory est = read_tum_trajectory(est_file);
  try {
    out.ate = compute_ate(gt, est, params.ate);
  } catch (const Error& e) {
    throw Error(est_file.string() + " vs " + gt_file.string() + ": " + e.what());
  }
  try {
    out.rpe = compute_rpe(gt, est, params.rpe);
  } catch (const Error& e) {
    out.rpe_error = e.what();
  }
  return out;
}

ReconstructionEvaluation evaluate_reconstruction_files(const std::filesystem::path& model_ply, const std::filesystem::path& gt_mesh,
                                                       const Pose& T_gt_model, const ReconstructionParams& params) {
  ReconstructionEvaluation out;
  out.model_file = model_ply;
  out.gt_file = gt_mesh;
  out.T_gt_model = T_gt_model;
  const auto points = transform_points(read_ply_points(model_ply), T_gt_model);
  if (points.empty()) throw Error("PLY file " + model_ply.string() + " has no vertices");
  const TriangleMesh mesh = read_gltf_triangles(gt_mesh);
  out.points = points.size();
  out.triangles = mesh.triangles.size();
  const MeshDistance distance(mesh);
  out.errors = compute_reconstruction_errors(points, distance, params);
  return out;
}

Pose parse_pose_text(std::string_view text) {
  std::string s(text);
  std::replace(s.begin(), s.end(), ',', ' ');
  std::istringstream ss(s);
  std::vector<double> v;
  std::string token;
  while (ss >> token) {
    std::size_t used = 0;
    double x = 0;
    try {
      x = std::stod(token, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != token.size() || !std::isfinite(x)) throw Error("pose '" + std::string(text) + "': '" + token + "' is not a number");
    v.push_back(x);
  }
  Pose T = Pose::Identity();
  if (v.size() == 7) {
    Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (q.norm() < 1e-9) throw Error("pose '" + std::string(text) + "': zero quaternion");
    T.linear() = q.normalized().toRotationMatrix();
    T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    return T;
  }
  if (v.size() == 16) {
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) M(r, c) = v[static_cast<std::size_t>(r * 4 + c)];
    const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0 ||
        (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
      throw Error("pose '" + std::string(text) + "': the 4x4 matrix is not a rigid transform");
    T.matrix() = M;
    return T;
  }
  throw Error("pose '" + std::string(text) + "': expected 7 numbers (tx ty tz qx qy qz qw) or 16 (4x4 row-major), got " +
              std::to_string(v.size()));
}

Pose pose_at_time(const Trajectory& trajectory, double t_s, double max_dt_s, const std::string& what) {
  const TimedPose* best = nullptr;
  for (const auto& p : trajectory)
    if (!best || std::abs(p.timestamp_s - t_s) < std::abs(best->timestamp_s - t_s)) best = &p;
  if (!best || std::abs(best->timestamp_s - t_s) > max_dt_s) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%.6f", t_s);
    throw Error(what + ": no pose within " + threshold_key(max_dt_s) + " s of t = " + buf);
  }
  return best->T_world_x;
}

// ---------------------------------------------------------------- JSON

nlohmann::json to_json(const ErrorStats& s) {
  return {{"count", s.count}, {"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
          {"std", s.std},     {"min", s.min},   {"max", s.max}};
}

nlohmann::json to_json(const TrajectoryEvaluation& e) {
  nlohmann::json j;
  j["gt"] = e.gt_file.string();
  j["est"] = e.est_file.string();
  j["ate"] = {{"pairs", e.ate.translation_m.count}, {"translation_m", to_json(e.ate.translation_m)}};
  nlohmann::json rpe = {{"delta", e.rpe_params.delta},
                        {"delta_unit", e.rpe_params.unit == RpeDeltaUnit::seconds ? "s" : "frames"}};
  if (e.rpe) {
    rpe["pairs"] = e.rpe->translation_m.count;
    rpe["translation_m"] = to_json(e.rpe->translation_m);
    rpe["rotation_deg"] = to_json(e.rpe->rotation_deg);
  } else {
    rpe["error"] = e.rpe_error;
  }
  j["rpe"] = rpe;
  return j;
}

nlohmann::json to_json(const SegmentationSummary& s) {
  nlohmann::json j;
  j["mean_label_iou"] = s.mean_label_iou;
  j["frames_evaluated"] = s.frames.size();
  j["frames_without_estimate"] = s.frames_without_estimate;
  j["unmatched_est_labels"] = s.unmatched_est_labels;
  j["labels"] = nlohmann::json::array();
  for (const auto& l : s.labels)
    j["labels"].push_back({{"gt_label", l.gt_label}, {"frames", l.frames}, {"frames_matched", l.frames_matched}, {"mean_iou", l.mean_iou}});
  j["frames"] = nlohmann::json::array();
  for (std::size_t f = 0; f < s.frames.size(); ++f) {
    nlohmann::json frame;
    frame["name"] = f < s.frame_names.size() ? s.frame_names[f] : std::to_string(f);
    frame["labels"] = nlohmann::json::array();
    for (const auto& l : s.frames[f].gt_labels)
      frame["labels"].push_back({{"gt_label", l.gt_label}, {"est_label", l.est_label}, {"iou", l.iou},
                                 {"gt_pixels", l.gt_pixels}, {"est_pixels", l.est_pixels}, {"intersection", l.intersection}});
    frame["unmatched_est_labels"] = s.frames[f].unmatched_est_labels;
    j["frames"].push_back(frame);
  }
  return j;
}

nlohmann::json to_json(const ReconstructionEvaluation& e) {
  nlohmann::json j;
  j["model"] = e.model_file.string();
  j["gt"] = e.gt_file.string();
  j["points"] = e.points;
  j["triangles"] = e.triangles;
  j["distance_m"] = to_json(e.errors.distance_m);
  j["share_above"] = nlohmann::json::array();
  for (std::size_t i = 0; i < e.errors.thresholds_m.size(); ++i)
    j["share_above"].push_back({{"threshold_m", e.errors.thresholds_m[i]}, {"share", e.errors.share_above[i]}});
  return j;
}

nlohmann::json to_json(const ObjectsEvaluation& e) {
  nlohmann::json j;
  j["objects"] = nlohmann::json::array();
  for (const auto& p : e.pairs) {
    const auto& r = p.errors;
    // [timestamp_s, drift m, drift deg(, drift relative to the camera m)] per matched stamp
    nlohmann::json series = nlohmann::json::array();
    for (const auto& d : r.drift_series) {
      nlohmann::json sample = {d.timestamp_s, d.translation_m, d.rotation_deg};
      if (std::isfinite(d.camera_relative_m)) sample.push_back(d.camera_relative_m);
      series.push_back(std::move(sample));
    }
    j["objects"].push_back({{"model_id", p.est_id},
                            {"gt_id", p.gt_id},
                            {"model_file", p.est_file.string()},
                            {"gt_file", p.gt_file.string()},
                            {"pairs", r.origin_ate.translation_m.count},
                            {"origin_ate_m", to_json(r.origin_ate.translation_m)},
                            {"tracked_point_ate_m", to_json(r.tracked_point_m)},
                            {"gt_origin_in_model", {r.gt_origin_in_model.x(), r.gt_origin_in_model.y(), r.gt_origin_in_model.z()}},
                            {"relative_translation_m", to_json(r.relative_translation_m)},
                            {"relative_rotation_deg", to_json(r.relative_rotation_deg)},
                            {"drift_translation_m", to_json(r.drift_translation_m)},
                            {"drift_rotation_deg", to_json(r.drift_rotation_deg)},
                            {"camera_relative_drift_m", to_json(r.camera_relative_drift_m)},
                            {"drift_series", series}});
  }
  j["drift_world"] = e.drift_world;
  j["unmatched_model_ids"] = e.unmatched_est_ids;
  j["unmatched_gt_ids"] = e.unmatched_gt_ids;
  return j;
}

// ---------------------------------------------------------------- text

std::string to_text(const TrajectoryEvaluation& e) {
  std::string out = line("ate_pairs", e.ate.translation_m.count);
  out += stats_lines("ate", "m", e.ate.translation_m);
  out += "rpe_delta " + threshold_key(e.rpe_params.delta) + (e.rpe_params.unit == RpeDeltaUnit::seconds ? " s\n" : " frames\n");
  if (e.rpe) {
    out += line("rpe_pairs", e.rpe->translation_m.count);
    out += stats_lines("rpe_trans", "m", e.rpe->translation_m);
    out += stats_lines("rpe_rot", "deg", e.rpe->rotation_deg);
  } else {
    out += "rpe_skipped " + e.rpe_error + "\n";
  }
  return out;
}

std::string to_text(const SegmentationSummary& s) {
  std::string out = line("frames_evaluated", s.frames.size());
  out += line("frames_without_estimate", s.frames_without_estimate);
  out += line("mean_label_iou", s.mean_label_iou);
  for (const auto& l : s.labels) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "label %d frames %zu matched %zu mean_iou %.6f\n", l.gt_label, l.frames, l.frames_matched, l.mean_iou);
    out += buf;
  }
  out += line("unmatched_est_labels", s.unmatched_est_labels);
  return out;
}

std::string to_text(const ReconstructionEvaluation& e) {
  std::string out = line("points", e.points);
  out += line("triangles", e.triangles);
  out += stats_lines("recon", "m", e.errors.distance_m);
  for (std::size_t i = 0; i < e.errors.thresholds_m.size(); ++i)
    out += line("recon_share_above_" + threshold_key(e.errors.thresholds_m[i]) + "_m", e.errors.share_above[i]);
  return out;
}

std::string to_text(const ObjectsEvaluation& e) {
  std::string out;
  for (const auto& p : e.pairs) {
    char buf[480];
    std::snprintf(buf, sizeof buf,
                  "object model %d gt %d pairs %zu origin_ate_rmse_m %.6f tracked_point_ate_rmse_m %.6f "
                  "relative_trans_rmse_m %.6f relative_rot_rmse_deg %.6f drift_trans_max_m %.6f drift_rot_max_deg %.6f",
                  p.est_id, p.gt_id, p.errors.origin_ate.translation_m.count, p.errors.origin_ate.translation_m.rmse,
                  p.errors.tracked_point_m.rmse, p.errors.relative_translation_m.rmse, p.errors.relative_rotation_deg.rmse,
                  p.errors.drift_translation_m.max, p.errors.drift_rotation_deg.max);
    out += buf;
    if (p.errors.camera_relative_drift_m.count > 0) {
      std::snprintf(buf, sizeof buf, " camera_relative_drift_max_m %.6f", p.errors.camera_relative_drift_m.max);
      out += buf;
    }
    out += "\n";
  }
  out += "drift_world " + e.drift_world + "\n";
  out += "unmatched_models";
  for (const int id : e.unmatched_est_ids) out += " " + std::to_string(id);
  out += "\nunmatched_gt";
  for (const int id : e.unmatched_gt_ids) out += " " + std::to_string(id);
  out += "\n";
  return out;
}

}  // namespace cofusion::eval
