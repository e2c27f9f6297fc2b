#include "commands/config.h"

#include <fstream>
#include <nlohmann/json.hpp>

#include "common/error.h"

namespace cofusion::commands {
namespace {
using nlohmann::json;

// Reads `key` from `object` into `value` when present, with an error naming file and key.
template <typename T>
void read(const json& object, const char* key, T& value, const std::string& where) {
  if (!object.contains(key)) return;
  try {
    value = object.at(key).get<T>();
  } catch (const json::exception&) {
    throw Error(where + "." + key + ": wrong type (" + object.at(key).dump() + ")");
  }
}

void check_keys(const json& object, std::initializer_list<const char*> known, const std::string& where) {
  if (!object.is_object()) throw Error(where + ": expected a JSON object");
  for (const auto& [key, value] : object.items()) {
    bool ok = false;
    for (const char* k : known) ok = ok || key == k;
    if (!ok) throw Error(where + ": unknown key '" + key + "'");
  }
}

}  // namespace

PipelineConfig load_config(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open config file " + path.string());
  json root;
  try {
    root = json::parse(in);
  } catch (const json::parse_error& e) {
    throw Error("config file " + path.string() + " is not valid JSON: " + e.what());
  }
  PipelineConfig config;
  const std::string file = path.string();
  check_keys(root, {"preprocess", "tracker", "fusion", "slam", "segmentation", "costs", "lifecycle", "motion_segmentation"},
             file);
  read(root, "motion_segmentation", config.motion_segmentation, file);
  if (root.contains("preprocess")) {
    const json& p = root["preprocess"];
    const std::string where = file + ": preprocess";
    check_keys(p, {"min_depth_m", "max_depth_m", "bilateral", "bilateral_radius_px", "bilateral_sigma_space_px",
                   "bilateral_sigma_depth_m", "pyramid_levels", "pyramid_max_depth_diff_m", "live_gradients"},
               where);
    auto& c = config.slam.preprocess;
    read(p, "min_depth_m", c.min_depth_m, where);
    read(p, "max_depth_m", c.max_depth_m, where);
    read(p, "bilateral", c.bilateral, where);
    read(p, "bilateral_radius_px", c.bilateral_radius_px, where);
    read(p, "bilateral_sigma_space_px", c.bilateral_sigma_space_px, where);
    read(p, "bilateral_sigma_depth_m", c.bilateral_sigma_depth_m, where);
    read(p, "pyramid_levels", c.pyramid_levels, where);
    read(p, "pyramid_max_depth_diff_m", c.pyramid_max_depth_diff_m, where);
    read(p, "live_gradients", c.live_gradients, where);
    if (!(c.min_depth_m >= 0 && c.max_depth_m > c.min_depth_m))
      throw Error(where + ": need 0 <= min_depth_m < max_depth_m");
    if (c.pyramid_levels < 1 || c.pyramid_levels > 8) throw Error(where + ".pyramid_levels: must be 1..8");
    if (c.bilateral_radius_px < 0 || c.bilateral_radius_px > 10) throw Error(where + ".bilateral_radius_px: must be 0..10");
    if (!(c.bilateral_sigma_space_px > 0 && c.bilateral_sigma_depth_m > 0))
      throw Error(where + ": bilateral sigmas must be positive");
  }
  if (root.contains("tracker")) {
    const json& p = root["tracker"];
    const std::string where = file + ": tracker";
    check_keys(p, {"iterations_per_level", "max_correspondence_distance_m", "max_normal_angle_deg", "use_photometric",
                   "photometric_weight", "max_intensity_diff", "photometric_huber_k", "min_correspondences",
                   "min_coarse_level_correspondences", "min_inlier_ratio",
                   "min_eigenvalue_ratio", "reduction_workgroups", "converged_translation_m",
                   "converged_rotation_rad"},
               where);
    auto& c = config.slam.tracker;
    read(p, "iterations_per_level", c.iterations_per_level, where);
    read(p, "max_correspondence_distance_m", c.max_correspondence_distance_m, where);
    read(p, "max_normal_angle_deg", c.max_normal_angle_deg, where);
    read(p, "use_photometric", c.use_photometric, where);
    read(p, "photometric_weight", c.photometric_weight, where);
    read(p, "max_intensity_diff", c.max_intensity_diff, where);
    read(p, "photometric_huber_k", c.photometric_huber_k, where);
    read(p, "min_correspondences", c.min_correspondences, where);
    read(p, "min_coarse_level_correspondences", c.min_coarse_level_correspondences, where);
    read(p, "min_inlier_ratio", c.min_inlier_ratio, where);
    read(p, "min_eigenvalue_ratio", c.min_eigenvalue_ratio, where);
    read(p, "reduction_workgroups", c.reduction_workgroups, where);
    read(p, "converged_translation_m", c.converged_translation_m, where);
    read(p, "converged_rotation_rad", c.converged_rotation_rad, where);
    for (int n : c.iterations_per_level)
      if (n < 0 || n > 100) throw Error(where + ".iterations_per_level: each must be 0..100");
  }
  if (root.contains("fusion")) {
    const json& p = root["fusion"];
    const std::string where = file + ": fusion";
    check_keys(p, {"index_map_scale", "index_map_footprint", "index_map_offset_penalty_rel", "max_depth_diff_rel", "max_normal_angle_deg",
                   "max_radius_growth", "stable_confidence", "unstable_window_frames", "free_space_margin_rel",
                   "free_space_penalty", "initial_capacity"},
               where);
    auto& c = config.slam.fusion;
    read(p, "index_map_scale", c.index_map_scale, where);
    read(p, "index_map_footprint", c.index_map_footprint, where);
    read(p, "index_map_offset_penalty_rel", c.index_map_offset_penalty_rel, where);
    read(p, "max_depth_diff_rel", c.max_depth_diff_rel, where);
    read(p, "max_normal_angle_deg", c.max_normal_angle_deg, where);
    read(p, "max_radius_growth", c.max_radius_growth, where);
    read(p, "stable_confidence", c.stable_confidence, where);
    read(p, "unstable_window_frames", c.unstable_window_frames, where);
    read(p, "free_space_margin_rel", c.free_space_margin_rel, where);
    read(p, "free_space_penalty", c.free_space_penalty, where);
    read(p, "initial_capacity", c.initial_capacity, where);
    if (c.index_map_scale < 1 || c.index_map_scale > 8) throw Error(where + ".index_map_scale: must be 1..8");
  }
  if (root.contains("slam")) {
    const json& p = root["slam"];
    const std::string where = file + ": slam";
    check_keys(p, {"constant_velocity_guess", "prediction_recent_window_frames"}, where);
    read(p, "constant_velocity_guess", config.slam.constant_velocity_guess, where);
    read(p, "prediction_recent_window_frames", config.slam.prediction_recent_window_frames, where);
  }
  if (root.contains("costs")) {
    const json& p = root["costs"];
    const std::string where = file + ": costs";
    check_keys(p, {"photometric_m", "photometric_reference_rms", "revealed_margin_m", "revealed_cost_m", "max_cost_m", "noise_reference_depth_m",
                   "max_explained_cost_m", "object_margin_px", "occluding_margin_m", "unseen_surface_cost_m",
                   "unseen_surface_reach_px"},
               where);
    read(p, "noise_reference_depth_m", config.costs.noise_reference_depth_m, where);
    read(p, "max_explained_cost_m", config.costs.max_explained_cost_m, where);
    auto& c = config.costs;
    read(p, "photometric_m", c.photometric_m, where);
    read(p, "photometric_reference_rms", c.photometric_reference_rms, where);
    read(p, "revealed_margin_m", c.revealed_margin_m, where);
    read(p, "revealed_cost_m", c.revealed_cost_m, where);
    read(p, "max_cost_m", c.max_cost_m, where);
    read(p, "object_margin_px", c.object_margin_px, where);
    read(p, "occluding_margin_m", c.occluding_margin_m, where);
    read(p, "unseen_surface_cost_m", c.unseen_surface_cost_m, where);
    read(p, "unseen_surface_reach_px", c.unseen_surface_reach_px, where);
    if (!(c.photometric_m >= 0 && c.revealed_margin_m > 0 && c.revealed_cost_m >= 0 && c.max_cost_m > 0 &&
          c.object_margin_px >= 0 && c.occluding_margin_m >= 0 && c.unseen_surface_cost_m >= 0 &&
          c.unseen_surface_reach_px >= 0))
      throw Error(where + ": costs and margins must be positive");
  }
  if (root.contains("lifecycle")) {
    const json& p = root["lifecycle"];
    const std::string where = file + ": lifecycle";
    check_keys(p, {"spawn_min_area_fraction", "warmup_frames", "spawn_max_camera_rotation_deg",
                   "spawn_max_camera_translation_m", "spawn_min_overlap", "spawn_max_velocity_guess_m",
                   "spawn_max_area_fraction",
                   "background_tracks_unclaimed_above", "max_active_models", "deactivate_after_frames",
                   "min_stable_surfels", "probation_frames", "static_translation_m", "static_rotation_deg",
                   "merge_window_frames", "merge_translation_m", "merge_rotation_deg", "duplicate_margin_rel",
                   "reactivate", "reactivate_min_inlier_ratio", "reactivate_max_rms_m", "object_min_inlier_ratio"},
               where);
    auto& c = config.lifecycle;
    read(p, "spawn_min_area_fraction", c.spawn_min_area_fraction, where);
    read(p, "warmup_frames", c.warmup_frames, where);
    read(p, "spawn_max_camera_rotation_deg", c.spawn_max_camera_rotation_deg, where);
    read(p, "spawn_max_camera_translation_m", c.spawn_max_camera_translation_m, where);
    read(p, "spawn_min_overlap", c.spawn_min_overlap, where);
    read(p, "spawn_max_velocity_guess_m", c.spawn_max_velocity_guess_m, where);
    read(p, "spawn_max_area_fraction", c.spawn_max_area_fraction, where);
    read(p, "background_tracks_unclaimed_above", c.background_tracks_unclaimed_above, where);
    read(p, "max_active_models", c.max_active_models, where);
    read(p, "deactivate_after_frames", c.deactivate_after_frames, where);
    read(p, "min_stable_surfels", c.min_stable_surfels, where);
    read(p, "probation_frames", c.probation_frames, where);
    read(p, "static_translation_m", c.static_translation_m, where);
    read(p, "static_rotation_deg", c.static_rotation_deg, where);
    read(p, "merge_window_frames", c.merge_window_frames, where);
    read(p, "merge_translation_m", c.merge_translation_m, where);
    read(p, "merge_rotation_deg", c.merge_rotation_deg, where);
    read(p, "duplicate_margin_rel", c.duplicate_margin_rel, where);
    read(p, "reactivate", c.reactivate, where);
    read(p, "reactivate_min_inlier_ratio", c.reactivate_min_inlier_ratio, where);
    read(p, "reactivate_max_rms_m", c.reactivate_max_rms_m, where);
    read(p, "object_min_inlier_ratio", c.object_min_inlier_ratio, where);
    if (!(c.spawn_min_area_fraction > 0 && c.spawn_min_area_fraction < 1))
      throw Error(where + ".spawn_min_area_fraction: must be in (0, 1)");
    if (c.max_active_models < 1 || c.max_active_models > 31) throw Error(where + ".max_active_models: must be 1..31");
    if (c.deactivate_after_frames < 1 || c.probation_frames < 1 || c.merge_window_frames < 1)
      throw Error(where + ": frame counts must be at least 1");
  }
  if (root.contains("segmentation")) {
    const json& p = root["segmentation"];
    const std::string where = file + ": segmentation";
    check_keys(p, {"slic", "crf", "cost_scale_m", "min_geometry_fraction", "no_geometry_cost_fraction",
                   "no_geometry_cost_min_m", "no_geometry_cost_max_m", "object_no_geometry_cost_max_m", "outlier_threshold",
                   "outlier_slope", "outlier_min_energy",
                   "min_component_px"},
               where);
    auto& c = config.segmentation;
    read(p, "cost_scale_m", c.cost_scale_m, where);
    read(p, "min_geometry_fraction", c.min_geometry_fraction, where);
    read(p, "no_geometry_cost_fraction", c.no_geometry_cost_fraction, where);
    read(p, "no_geometry_cost_min_m", c.no_geometry_cost_min_m, where);
    read(p, "no_geometry_cost_max_m", c.no_geometry_cost_max_m, where);
    read(p, "object_no_geometry_cost_max_m", c.object_no_geometry_cost_max_m, where);
    read(p, "outlier_threshold", c.outlier_threshold, where);
    read(p, "outlier_slope", c.outlier_slope, where);
    read(p, "outlier_min_energy", c.outlier_min_energy, where);
    read(p, "min_component_px", c.min_component_px, where);
    if (p.contains("slic")) {
      const json& q = p["slic"];
      const std::string w = where + ".slic";
      check_keys(q, {"superpixel_size_px", "compactness", "iterations", "coarse_to_fine", "depth_weight_per_m",
                     "min_piece_fraction"},
                 w);
      read(q, "superpixel_size_px", c.slic.superpixel_size_px, w);
      read(q, "compactness", c.slic.compactness, w);
      read(q, "iterations", c.slic.iterations, w);
      read(q, "coarse_to_fine", c.slic.coarse_to_fine, w);
      read(q, "depth_weight_per_m", c.slic.depth_weight_per_m, w);
      read(q, "min_piece_fraction", c.slic.min_piece_fraction, w);
    }
    if (p.contains("crf")) {
      const json& q = p["crf"];
      const std::string w = where + ".crf";
      check_keys(q, {"iterations", "appearance_weight", "sigma_colour", "sigma_depth_m", "sigma_position",
                     "smoothness_weight", "sigma_smoothness", "method", "exact_cutoff"},
                 w);
      read(q, "iterations", c.crf.iterations, w);
      read(q, "appearance_weight", c.crf.appearance_weight, w);
      read(q, "sigma_colour", c.crf.sigma_colour, w);
      read(q, "sigma_depth_m", c.crf.sigma_depth_m, w);
      read(q, "sigma_position", c.crf.sigma_position, w);
      read(q, "smoothness_weight", c.crf.smoothness_weight, w);
      read(q, "sigma_smoothness", c.crf.sigma_smoothness, w);
      read(q, "exact_cutoff", c.crf.exact_cutoff, w);
      if (q.contains("method")) {
        const std::string method = q["method"].is_string() ? q["method"].get<std::string>() : "";
        if (method == "exact")
          c.crf.method = segmentation::CrfMethod::kExact;
        else if (method == "permutohedral")
          c.crf.method = segmentation::CrfMethod::kPermutohedral;
        else
          throw Error(w + ".method: expected \"exact\" or \"permutohedral\"");
      }
    }
    // The segmenter validates the rest (it throws naming the parameter).
    try {
      segmentation::MotionSegmenter check(c);
    } catch (const Error& e) {
      throw Error(where + ": " + e.what());
    }
  }
  return config;
}

}  // namespace cofusion::commands
