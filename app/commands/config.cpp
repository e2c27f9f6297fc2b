#include "commands/config.h"

#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <vector>

#include "common/error.h"

namespace cofusion::commands {
namespace {
using nlohmann::json;

// One JSON object of the file. Each key is named once, where it is read into its member; keys
// that nothing read are errors (usually typos). Errors name the file, the section and the key.
class Section {
 public:
  Section(const json& object, std::string where) : object_(object), where_(std::move(where)) {
    if (!object_.is_object()) throw Error(where_ + ": expected a JSON object");
  }

  const std::string& where() const { return where_; }

  // Reads `key` into `value` when present.
  template <typename T>
  Section& field(const char* key, T& value) {
    known_.push_back(key);
    if (!object_.contains(key)) return *this;
    try {
      value = object_.at(key).get<T>();
    } catch (const json::exception&) {
      throw Error(where_ + "." + key + ": wrong type (" + object_.at(key).dump() + ")");
    }
    return *this;
  }

  // Reads the nested object `key` (when present) with `read`, which names its members.
  Section& section(const char* key, const std::string& where, const std::function<void(Section&)>& read) {
    known_.push_back(key);
    if (!object_.contains(key)) return *this;
    Section nested(object_.at(key), where);
    read(nested);
    nested.reject_unknown();
    return *this;
  }

  // Raw access for a member that needs its own parsing; `key` counts as known.
  const json* raw(const char* key) {
    known_.push_back(key);
    return object_.contains(key) ? &object_.at(key) : nullptr;
  }

  void reject_unknown() const {
    for (const auto& [key, value] : object_.items()) {
      bool ok = false;
      for (const char* k : known_) ok = ok || key == k;
      if (!ok) throw Error(where_ + ": unknown key '" + key + "'");
    }
  }

 private:
  const json& object_;
  std::string where_;
  std::vector<const char*> known_;
};

void read_preprocess(Section& s, kernels::PreprocessParams& c) {
  s.field("min_depth_m", c.min_depth_m)
      .field("max_depth_m", c.max_depth_m)
      .field("bilateral", c.bilateral)
      .field("bilateral_radius_px", c.bilateral_radius_px)
      .field("bilateral_sigma_space_px", c.bilateral_sigma_space_px)
      .field("bilateral_sigma_depth_m", c.bilateral_sigma_depth_m)
      .field("pyramid_levels", c.pyramid_levels)
      .field("pyramid_max_depth_diff_m", c.pyramid_max_depth_diff_m)
      .field("live_gradients", c.live_gradients);
  const std::string& where = s.where();
  if (!(c.min_depth_m >= 0 && c.max_depth_m > c.min_depth_m)) throw Error(where + ": need 0 <= min_depth_m < max_depth_m");
  if (c.pyramid_levels < 1 || c.pyramid_levels > 8) throw Error(where + ".pyramid_levels: must be 1..8");
  if (c.bilateral_radius_px < 0 || c.bilateral_radius_px > 10) throw Error(where + ".bilateral_radius_px: must be 0..10");
  if (!(c.bilateral_sigma_space_px > 0 && c.bilateral_sigma_depth_m > 0))
    throw Error(where + ": bilateral sigmas must be positive");
}

// Gauss-Newton iterations per pyramid level (tracker and object trackers).
void require_iteration_counts(const std::vector<int>& counts, const std::string& where) {
  for (int n : counts)
    if (n < 0 || n > 100) throw Error(where + ": each must be 0..100");
}

void read_tracker(Section& s, slam::TrackerParams& c) {
  s.field("iterations_per_level", c.iterations_per_level)
      .field("max_correspondence_distance_m", c.max_correspondence_distance_m)
      .field("max_normal_angle_deg", c.max_normal_angle_deg)
      .field("use_photometric", c.use_photometric)
      .field("photometric_weight", c.photometric_weight)
      .field("esm_gradient", c.esm_gradient)
      .field("outline_photometric", c.outline_photometric)
      .field("photometric_skip_rim", c.photometric_skip_rim)
      .field("outline_occlusion_margin_m", c.outline_occlusion_margin_m)
      .field("max_intensity_diff", c.max_intensity_diff)
      .field("photometric_huber_k", c.photometric_huber_k)
      .field("icp_huber_k", c.icp_huber_k)
      .field("outline_huber_scale", c.outline_huber_scale)
      .field("icp_noise_reference_depth_m", c.icp_noise_reference_depth_m)
      .field("photometric_gradient_c", c.photometric_gradient_c)
      .field("photometric_cauchy_k", c.photometric_cauchy_k)
      .field("exposure_compensation", c.exposure_compensation)
      .field("max_exposure_gain", c.max_exposure_gain)
      .field("min_correspondences", c.min_correspondences)
      .field("min_coarse_level_correspondences", c.min_coarse_level_correspondences)
      .field("min_inlier_ratio", c.min_inlier_ratio)
      .field("min_eigenvalue_ratio", c.min_eigenvalue_ratio)
      .field("max_step_translation_m", c.max_step_translation_m)
      .field("max_step_rotation_deg", c.max_step_rotation_deg)
      .field("max_translation_from_guess_m", c.max_translation_from_guess_m)
      .field("max_rotation_from_guess_deg", c.max_rotation_from_guess_deg)
      .field("reduction_workgroups", c.reduction_workgroups)
      .field("converged_translation_m", c.converged_translation_m)
      .field("converged_rotation_rad", c.converged_rotation_rad);
  require_iteration_counts(c.iterations_per_level, s.where() + ".iterations_per_level");
}

void read_fusion(Section& s, slam::FusionParams& c) {
  s.field("index_map_scale", c.index_map_scale)
      .field("index_map_footprint", c.index_map_footprint)
      .field("index_map_offset_penalty_rel", c.index_map_offset_penalty_rel)
      .field("max_depth_diff_rel", c.max_depth_diff_rel)
      .field("max_normal_angle_deg", c.max_normal_angle_deg)
      .field("max_radius_growth", c.max_radius_growth)
      .field("stable_confidence", c.stable_confidence)
      .field("unstable_window_frames", c.unstable_window_frames)
      .field("free_space_margin_rel", c.free_space_margin_rel)
      .field("free_space_penalty", c.free_space_penalty)
      .field("merge_window_cells", c.merge_window_cells)
      .field("merge_window_step_cells", c.merge_window_step_cells)
      .field("merge_distance_rel", c.merge_distance_rel)
      .field("merge_max_normal_angle_deg", c.merge_max_normal_angle_deg)
      .field("merge_max_source_confidence", c.merge_max_source_confidence)
      .field("new_surfel_clearance_cells", c.new_surfel_clearance_cells)
      .field("initial_capacity", c.initial_capacity)
      .field("max_surfels", c.max_surfels)
      .field("cull_keep_fraction", c.cull_keep_fraction);
  if (c.index_map_scale < 1 || c.index_map_scale > 8) throw Error(s.where() + ".index_map_scale: must be 1..8");
  if (c.new_surfel_clearance_cells < 0 || c.new_surfel_clearance_cells > 8)
    throw Error(s.where() + ".new_surfel_clearance_cells: must be 0..8");
  if (c.merge_window_cells < 0 || c.merge_window_cells > 8) throw Error(s.where() + ".merge_window_cells: must be 0..8");
  if (c.merge_window_step_cells < 1 || c.merge_window_step_cells > 8)
    throw Error(s.where() + ".merge_window_step_cells: must be 1..8");
  if (!(c.merge_distance_rel >= 0.0f)) throw Error(s.where() + ".merge_distance_rel: must be >= 0 (0: no merging)");
  if (!(c.cull_keep_fraction > 0.0f && c.cull_keep_fraction <= 1.0f))
    throw Error(s.where() + ".cull_keep_fraction: must be in (0, 1]");
}

void read_costs(Section& s, slam::MotionCostParams& c) {
  s.field("photometric_m", c.photometric_m)
      .field("photometric_reference_rms", c.photometric_reference_rms)
      .field("revealed_margin_m", c.revealed_margin_m)
      .field("revealed_cost_m", c.revealed_cost_m)
      .field("max_cost_m", c.max_cost_m)
      .field("noise_reference_depth_m", c.noise_reference_depth_m)
      .field("max_explained_cost_m", c.max_explained_cost_m)
      .field("background_takes_unmodelled", c.background_takes_unmodelled)
      .field("object_margin_px", c.object_margin_px)
      .field("occluding_margin_m", c.occluding_margin_m)
      .field("unseen_surface_cost_m", c.unseen_surface_cost_m)
      .field("unseen_surface_reach_px", c.unseen_surface_reach_px);
  if (!(c.photometric_m >= 0 && c.revealed_margin_m > 0 && c.revealed_cost_m >= 0 && c.max_cost_m > 0 &&
        c.object_margin_px >= 0 && c.occluding_margin_m >= 0 && c.unseen_surface_cost_m >= 0 &&
        c.unseen_surface_reach_px >= 0))
    throw Error(s.where() + ": costs and margins must be positive");
}

void read_lifecycle(Section& s, slam::LifecycleParams& c) {
  s.field("spawn_min_area_fraction", c.spawn_min_area_fraction)
      .field("spawn_keep_area_fraction", c.spawn_keep_area_fraction)
      .field("hold_spawn_candidates", c.hold_spawn_candidates)
      .field("warmup_frames", c.warmup_frames)
      .field("spawn_max_camera_rotation_deg", c.spawn_max_camera_rotation_deg)
      .field("spawn_max_camera_translation_m", c.spawn_max_camera_translation_m)
      .field("spawn_steady_frames", c.spawn_steady_frames)
      .field("spawn_min_overlap", c.spawn_min_overlap)
      .field("spawn_persist_frames", c.spawn_persist_frames)
      .field("spawn_persist_min_area_fraction", c.spawn_persist_min_area_fraction)
      .field("spawn_persist_mover_clearance_px", c.spawn_persist_mover_clearance_px)
      .field("spawn_persist_min_travel_rel", c.spawn_persist_min_travel_rel)
      .field("spawn_persist_min_straightness", c.spawn_persist_min_straightness)
      .field("spawn_max_velocity_guess_m", c.spawn_max_velocity_guess_m)
      .field("spawn_max_area_fraction", c.spawn_max_area_fraction)
      .field("background_tracks_unclaimed_above", c.background_tracks_unclaimed_above)
      .field("max_active_models", c.max_active_models)
      .field("coast_frames", c.coast_frames)
      .field("coast_border_px", c.coast_border_px)
      .field("deactivate_after_frames", c.deactivate_after_frames)
      .field("min_stable_surfels", c.min_stable_surfels)
      .field("probation_frames", c.probation_frames)
      .field("static_translation_m", c.static_translation_m)
      .field("static_rotation_deg", c.static_rotation_deg)
      .field("merge_window_frames", c.merge_window_frames)
      .field("merge_translation_m", c.merge_translation_m)
      .field("merge_rotation_deg", c.merge_rotation_deg)
      .field("merge_history_translation_m", c.merge_history_translation_m)
      .field("merge_history_rotation_deg", c.merge_history_rotation_deg)
      .field("duplicate_margin_rel", c.duplicate_margin_rel)
      .field("reactivate", c.reactivate)
      .field("reactivate_min_inlier_ratio", c.reactivate_min_inlier_ratio)
      .field("reactivate_max_rms_m", c.reactivate_max_rms_m)
      .field("object_min_inlier_ratio", c.object_min_inlier_ratio)
      .field("object_outline_photometric", c.object_outline_photometric)
      .field("object_outline_at_border", c.object_outline_at_border)
      .field("object_photometric_skip_rim", c.object_photometric_skip_rim)
      .field("border_unpaired_cost", c.border_unpaired_cost)
      .field("border_still_min_gain", c.border_still_min_gain)
      .field("object_photometric_weight", c.object_photometric_weight)
      .field("object_max_intensity_diff", c.object_max_intensity_diff)
      .field("object_photometric_huber_k", c.object_photometric_huber_k)
      .field("object_outline_huber_scale", c.object_outline_huber_scale)
      .field("object_icp_noise_reference_depth_m", c.object_icp_noise_reference_depth_m)
      .field("object_iterations_per_level", c.object_iterations_per_level)
      .field("rising_min_cost_m", c.rising_min_cost_m)
      .field("rising_min_step_m", c.rising_min_step_m)
      .field("rising_min_area_fraction", c.rising_min_area_fraction)
      .field("rising_max_cost_m", c.rising_max_cost_m)
      .field("slide_min_shift_px", c.slide_min_shift_px)
      .field("slide_min_intensity", c.slide_min_intensity)
      .field("slide_min_fraction", c.slide_min_fraction);
  require_iteration_counts(c.object_iterations_per_level, s.where() + ".object_iterations_per_level");
  const std::string& where = s.where();
  if (!(c.spawn_min_area_fraction > 0 && c.spawn_min_area_fraction < 1))
    throw Error(where + ".spawn_min_area_fraction: must be in (0, 1)");
  if (!(c.spawn_keep_area_fraction >= 0 && c.spawn_keep_area_fraction <= c.spawn_min_area_fraction))
    throw Error(where + ".spawn_keep_area_fraction: must be in [0, spawn_min_area_fraction]");
  if (!(c.spawn_persist_min_area_fraction >= 0 && c.spawn_persist_min_area_fraction < 1))
    throw Error(where + ".spawn_persist_min_area_fraction: must be in [0, 1)");
  if (c.spawn_persist_mover_clearance_px < 0) throw Error(where + ".spawn_persist_mover_clearance_px: must be >= 0");
  if (c.spawn_persist_frames < 0 || !(c.spawn_persist_min_travel_rel >= 0) ||
      !(c.spawn_persist_min_straightness >= 0 && c.spawn_persist_min_straightness <= 1))
    throw Error(where + ".spawn_persist_*: frames and travel must be >= 0, straightness in [0, 1]");
  if (!(c.rising_min_cost_m >= 0 && c.rising_min_step_m >= 0 && c.rising_max_cost_m >= 0 && c.rising_min_area_fraction >= 0 &&
        c.rising_min_area_fraction < 1))
    throw Error(where + ".rising_*: costs must be >= 0 and rising_min_area_fraction in [0, 1)");
  if (!(c.slide_min_shift_px >= 0 && c.slide_min_intensity >= 0 && c.slide_min_fraction >= 0 && c.slide_min_fraction <= 1))
    throw Error(where + ".slide_*: must be >= 0, slide_min_fraction at most 1");
  if (!(c.object_photometric_weight >= 0)) throw Error(where + ".object_photometric_weight: must be >= 0");
  if (!(c.border_unpaired_cost >= 0)) throw Error(where + ".border_unpaired_cost: must be >= 0");
  if (!(c.border_still_min_gain >= 0 && c.border_still_min_gain < 1))
    throw Error(where + ".border_still_min_gain: must be in [0, 1)");
  if (!(c.object_max_intensity_diff > 0)) throw Error(where + ".object_max_intensity_diff: must be > 0");
  if (!(c.object_photometric_huber_k >= 0)) throw Error(where + ".object_photometric_huber_k: must be >= 0");
  if (!(c.object_outline_huber_scale >= 0)) throw Error(where + ".object_outline_huber_scale: must be >= 0");
  if (!(c.object_icp_noise_reference_depth_m >= 0))
    throw Error(where + ".object_icp_noise_reference_depth_m: must be >= 0");
  if (c.max_active_models < 1 || c.max_active_models > 31) throw Error(where + ".max_active_models: must be 1..31");
  if (c.spawn_steady_frames < 1 || c.spawn_steady_frames > 16)
    throw Error(where + ".spawn_steady_frames: must be 1..16 (the camera history's length)");
  if (c.deactivate_after_frames < 1 || c.probation_frames < 1 || c.merge_window_frames < 1)
    throw Error(where + ": frame counts must be at least 1");
  s.section("probation_observed", where + ".probation_observed", [&](Section& q) {
    slam::ObservedMotionParams& o = c.probation_observed;
    q.field("points", o.points)
        .field("depth_sigmas", o.depth_sigmas)
        .field("max_intensity_diff", o.max_intensity_diff)
        .field("max_still_ratio", o.max_still_ratio)
        .field("min_counted", o.min_counted);
    if (o.points < 0 || !(o.depth_sigmas > 0) || !(o.max_intensity_diff > 0) ||
        !(o.max_still_ratio >= 0 && o.max_still_ratio <= 1) || !(o.min_counted >= 0 && o.min_counted <= 1))
      throw Error(q.where() + ": points must be >= 0, depth_sigmas and max_intensity_diff > 0, max_still_ratio and "
                              "min_counted in [0, 1]");
  });
  s.section("spawn_rigidity", where + ".spawn_rigidity", [&](Section& q) {
    slam::RegionRigidityParams& r = c.spawn_rigidity;
    q.field("enabled", r.enabled)
        .field("step", r.step)
        .field("iterations", r.iterations)
        .field("association_m", r.association_m)
        .field("huber_m", r.huber_m)
        .field("min_aligned_fraction", r.min_aligned_fraction)
        .field("normal_max_depth_step_m", r.normal_max_depth_step_m);
    if (r.step < 1 || r.iterations < 0 || !(r.association_m > 0) || !(r.huber_m > 0) ||
        !(r.min_aligned_fraction >= 0 && r.min_aligned_fraction <= 1) || !(r.normal_max_depth_step_m > 0))
      throw Error(q.where() + ": step must be >= 1, iterations >= 0, distances > 0 and min_aligned_fraction in [0, 1]");
  });
}

void read_segmentation(Section& s, segmentation::MotionSegmentationParams& c) {
  s.field("cost_scale_m", c.cost_scale_m)
      .field("min_geometry_fraction", c.min_geometry_fraction)
      .field("no_geometry_cost_fraction", c.no_geometry_cost_fraction)
      .field("no_geometry_cost_min_m", c.no_geometry_cost_min_m)
      .field("no_geometry_cost_max_m", c.no_geometry_cost_max_m)
      .field("object_no_geometry_cost_max_m", c.object_no_geometry_cost_max_m)
      .field("outlier_threshold", c.outlier_threshold)
      .field("outlier_slope", c.outlier_slope)
      .field("outlier_min_energy", c.outlier_min_energy)
      .field("min_component_px", c.min_component_px)
      .field("min_object_component_px", c.min_object_component_px);
  s.section("slic", s.where() + ".slic", [&](Section& q) {
    q.field("superpixel_size_px", c.slic.superpixel_size_px)
        .field("compactness", c.slic.compactness)
        .field("iterations", c.slic.iterations)
        .field("coarse_to_fine", c.slic.coarse_to_fine)
        .field("depth_weight_per_m", c.slic.depth_weight_per_m)
        .field("min_piece_fraction", c.slic.min_piece_fraction);
  });
  s.section("crf", s.where() + ".crf", [&](Section& q) {
    q.field("iterations", c.crf.iterations)
        .field("appearance_weight", c.crf.appearance_weight)
        .field("sigma_colour", c.crf.sigma_colour)
        .field("sigma_depth_m", c.crf.sigma_depth_m)
        .field("sigma_position", c.crf.sigma_position)
        .field("smoothness_weight", c.crf.smoothness_weight)
        .field("sigma_smoothness", c.crf.sigma_smoothness)
        .field("exact_cutoff", c.crf.exact_cutoff);
    if (const json* m = q.raw("method")) {
      const std::string method = m->is_string() ? m->get<std::string>() : "";
      if (method == "exact")
        c.crf.method = segmentation::CrfMethod::kExact;
      else if (method == "permutohedral")
        c.crf.method = segmentation::CrfMethod::kPermutohedral;
      else if (method == "auto")
        c.crf.method = segmentation::CrfMethod::kAuto;
      else
        throw Error(q.where() + ".method: expected \"exact\", \"permutohedral\" or \"auto\"");
    }
  });
  // The segmenter validates the rest (it throws naming the parameter).
  try {
    segmentation::MotionSegmenter check(c);
  } catch (const Error& e) {
    throw Error(s.where() + ": " + e.what());
  }
}

}  // namespace

PipelineConfig load_config(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open config file " + path.string());
  json root;
  try {
    root = json::parse(in);
  } catch (const json::exception& e) {  // parse_error, or out_of_range for a number beyond double
    throw Error("config file " + path.string() + " is not valid JSON: " + e.what());
  }
  PipelineConfig config;
  const std::string file = path.string();
  Section s(root, file);
  s.field("motion_segmentation", config.motion_segmentation);
  s.section("preprocess", file + ": preprocess", [&](Section& q) { read_preprocess(q, config.slam.preprocess); });
  s.section("tracker", file + ": tracker", [&](Section& q) { read_tracker(q, config.slam.tracker); });
  s.section("fusion", file + ": fusion", [&](Section& q) { read_fusion(q, config.slam.fusion); });
  s.section("slam", file + ": slam", [&](Section& q) {
    q.field("constant_velocity_guess", config.slam.constant_velocity_guess)
        .field("prediction_recent_window_frames", config.slam.prediction_recent_window_frames);
  });
  s.section("costs", file + ": costs", [&](Section& q) { read_costs(q, config.costs); });
  s.section("lifecycle", file + ": lifecycle", [&](Section& q) { read_lifecycle(q, config.lifecycle); });
  s.section("segmentation", file + ": segmentation", [&](Section& q) { read_segmentation(q, config.segmentation); });
  s.section("semantic", file + ": semantic", [&](Section& q) {
    // Mode, excluded and modelled classes come from the command line (--segmentation, --exclude,
    // --classes); the thresholds from here.
    q.field("confirm_frames", config.semantic.confirm_frames)
        .field("min_instance_area_fraction", config.semantic.min_instance_area_fraction)
        .field("join_min_iou", config.semantic.join_min_iou)
        .field("exclude_margin_px", config.semantic.exclude_margin_px)
        .field("resting_max_unexplained_fraction", config.semantic.resting_max_unexplained_fraction)
        .field("track_woken", config.semantic.track_woken);
    if (config.semantic.exclude_margin_px < 0 || config.semantic.exclude_margin_px > 64)
      throw Error(q.where() + ".exclude_margin_px: must be 0..64");
    if (config.semantic.confirm_frames < 1 ||
        !(config.semantic.min_instance_area_fraction >= 0 && config.semantic.min_instance_area_fraction <= 1) ||
        !(config.semantic.join_min_iou > 0 && config.semantic.join_min_iou <= 1) ||
        !(config.semantic.resting_max_unexplained_fraction >= 0 && config.semantic.resting_max_unexplained_fraction <= 1))
      throw Error(q.where() + ": confirm_frames must be >= 1, min_instance_area_fraction in [0, 1], join_min_iou in (0, 1] "
                  "and resting_max_unexplained_fraction in [0, 1]");
  });
  s.section("rest", file + ": rest", [&](Section& q) {
    q.field("prefer_rest", config.rest.prefer_rest)
        .field("max_cost_increase", config.rest.max_cost_increase)
        .field("min_correspondence_fraction", config.rest.min_correspondence_fraction);
    if (!(config.rest.max_cost_increase >= 0) ||
        !(config.rest.min_correspondence_fraction >= 0 && config.rest.min_correspondence_fraction <= 1))
      throw Error(q.where() + ": max_cost_increase must be >= 0 and min_correspondence_fraction in [0, 1]");
  });
  s.section("camera_check", file + ": camera_check", [&](Section& q) {
    q.field("enabled", config.camera_check.enabled)
        .field("step_px", config.camera_check.step_px)
        .field("tolerance_rel", config.camera_check.tolerance_rel)
        .field("tolerance_m", config.camera_check.tolerance_m)
        .field("min_fit_ratio", config.camera_check.min_fit_ratio)
        .field("photometric_weight", config.camera_check.photometric_weight)
        .field("retry_photometric_weight", config.camera_check.retry_photometric_weight)
        .field("photometric_tile_cap", config.camera_check.photometric_tile_cap)
        .field("replaced_motion_scale", config.camera_check.replaced_motion_scale)
        .field("agreeing_frames", config.camera_check.agreeing_frames)
        .field("keyframe_pose_gain", config.camera_check.keyframe_pose_gain)
        .field("keyframe_pull_gain", config.camera_check.keyframe_pull_gain)
        .field("keyframe_pull_min_inliers", config.camera_check.keyframe_pull_min_inliers);
    const auto& c = config.camera_check;
    if (c.step_px < 1 || !(c.tolerance_rel >= 0) || !(c.tolerance_m >= 0) ||
        !(c.min_fit_ratio >= 0 && c.min_fit_ratio <= 1) || !(c.photometric_weight >= 0) ||
        !(c.retry_photometric_weight >= 0) || !(c.photometric_tile_cap >= 0) ||
        !(c.replaced_motion_scale >= 0 && c.replaced_motion_scale <= 1) || c.agreeing_frames < 0 ||
        !(c.keyframe_pose_gain >= 0 && c.keyframe_pose_gain <= 1) ||
        !(c.keyframe_pull_gain >= 0 && c.keyframe_pull_gain <= 1) || c.keyframe_pull_min_inliers < 0)
      throw Error(q.where() + ": step_px must be >= 1, tolerances, photometric weights and photometric_tile_cap >= 0, "
                              "min_fit_ratio, replaced_motion_scale, keyframe_pose_gain and keyframe_pull_gain in "
                              "[0, 1], agreeing_frames and keyframe_pull_min_inliers >= 0");
  });
  s.section("retrack", file + ": retrack", [&](Section& q) {
    auto& r = config.retrack;
    q.field("min_taken_fraction", r.min_taken_fraction)
        .field("min_region_fraction", r.min_region_fraction)
        .field("surge_factor", r.surge_factor)
        .field("baseline_frames", r.baseline_frames)
        .field("max_correction_m", r.max_correction_m)
        .field("max_correction_deg", r.max_correction_deg);
    if (!(r.min_taken_fraction >= 0 && r.min_taken_fraction <= 1) ||
        !(r.min_region_fraction >= 0 && r.min_region_fraction <= 1) || !(r.surge_factor >= 0) ||
        r.baseline_frames < 0 || !(r.max_correction_m >= 0) || !(r.max_correction_deg >= 0))
      throw Error(q.where() + ": min_taken_fraction and min_region_fraction must be in [0, 1], surge_factor, "
                              "baseline_frames and the max_correction_* >= 0");
  });
  s.section("rolling_shutter", file + ": rolling_shutter", [&](Section& q) {
    double readout_s = config.slam.rolling_shutter.colour_readout_s.value_or(0.0);
    q.field("colour_readout_s", readout_s).field("nominal_frame_interval_s", config.slam.rolling_shutter.nominal_frame_interval_s);
    if (q.raw("colour_readout_s")) config.slam.rolling_shutter.colour_readout_s = readout_s;
    if (!(std::abs(readout_s) <= 1.0) || !(config.slam.rolling_shutter.nominal_frame_interval_s > 0))
      throw Error(q.where() + ": colour_readout_s must be within -1..1 s and nominal_frame_interval_s > 0");
  });
  s.reject_unknown();
  return config;
}

}  // namespace cofusion::commands
