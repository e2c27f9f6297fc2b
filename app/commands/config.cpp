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
  check_keys(root, {"preprocess", "tracker", "fusion", "slam"}, file);
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
                   "photometric_weight", "max_intensity_diff", "min_correspondences", "min_inlier_ratio",
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
    read(p, "min_correspondences", c.min_correspondences, where);
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
    check_keys(p, {"index_map_scale", "index_map_footprint", "max_depth_diff_rel", "max_normal_angle_deg",
                   "max_radius_growth", "stable_confidence", "unstable_window_frames", "free_space_margin_rel",
                   "free_space_penalty", "initial_capacity"},
               where);
    auto& c = config.slam.fusion;
    read(p, "index_map_scale", c.index_map_scale, where);
    read(p, "index_map_footprint", c.index_map_footprint, where);
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
  return config;
}

}  // namespace cofusion::commands
