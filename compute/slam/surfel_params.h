#pragma once
// Parameters of surfel prediction and fusion. Defaults follow ElasticFusion / Co-Fusion where
// they have one; units in the names.

namespace cofusion::slam {

struct PredictionParams {
  // Surfels below this confidence are left out of the predicted view ...
  float min_confidence = 0.0f;
  // ... unless created within this many frames (young models have no stable surfels yet).
  int recent_window_frames = 1 << 30;
  // Half-size in pixels of the square a surfel covers when its disc is larger than a pixel.
  int footprint_px = 1;
  // Within that square a pixel takes the surfel whose plane its ray meets nearest, plus this
  // fraction of the depth per squared pixel of distance from the surfel's projected centre (2 mm
  // per pixel^2 at 1 m): surfels of one surface then win the pixels nearest to them, while a
  // surface a centimetre or more in front still hides one behind.
  float offset_penalty_rel = 0.002f;
};

struct FusionParams {
  // Resolution multiplier of the index map used for data association (ElasticFusion: 4) ...
  int index_map_scale = 2;
  // ... and the half-size (in its cells) of the square each surfel covers there when its disc is
  // larger than a cell. With one cell per surfel, about a third of the pixels find no candidate
  // although a surfel covers them, and spawn duplicates that the window then has to remove.
  int index_map_footprint = 1;
  // ... with the prediction's nearest-surfel rule (PredictionParams::offset_penalty_rel; its
  // distance is in full-resolution pixels).
  float index_map_offset_penalty_rel = 0.002f;
  // A live pixel matches a surfel within max_depth_diff_rel * depth + 5 mm ...
  float max_depth_diff_rel = 0.03f;
  // ... whose normal is within this angle of the live normal. Generous: normals of real sensor
  // depth at 2-4 m are noisy, and a tight test turns noise into duplicate surfels.
  float max_normal_angle_deg = 70.0f;
  // A pixel no surfel of its index-map block explains spawns a new surfel only when no surfel in
  // this many cells around the block is within the depth tolerance either (0: the block alone).
  // Seen from a new angle, pixel rays fall between known surfels; without this, every such gap
  // became a new surfel (TUM fr1/rpy: about 15k per frame, a third of the map unconfirmed).
  int new_surfel_clearance_cells = 1;
  // Position/normal/radius are averaged only when the live disc is at most this much larger.
  float max_radius_growth = 1.5f;
  // Surfels at or above this confidence are stable (ElasticFusion: 10 with weights <= 1).
  float stable_confidence = 6.0f;
  // Unstable surfels not confirmed within this many frames of their creation are removed.
  int unstable_window_frames = 30;
  // A surfel more than this fraction of the live depth in front of the live surface is in free space ...
  float free_space_margin_rel = 0.06f;
  // ... and loses this much confidence per such observation (removed at zero).
  float free_space_penalty = 1.0f;
  // Duplicate surfels are merged after each fusion (surfel_merge_select/claim, applied in the
  // cleanup): a surfel merges into a more confident one found within merge_window_cells cells of
  // its projection in the fusion's index map (half-size of the square searched; cells are 1 /
  // index_map_scale pixels) ...
  int merge_window_cells = 2;
  // ... looking at every merge_window_step_cells-th cell of that square in x and y (1: all). A
  // surfel holds a block of about 2x2 cells of the index map (index_map_footprint 1 at scale 2),
  // which every second cell meets; the search is the costliest kernel of a frame, its time grows
  // with the cells looked at (lavapipe runs the loop body for all lanes of a SIMD group).
  int merge_window_step_cells = 2;
  // ... that lies within this fraction of the larger of the two radii (m per m; 0 switches
  // merging off). New surfels fill the gaps between the surfels of a surface seen from a new
  // angle; without merging they pile up, about 1.2M surfels on TUM fr1/rpy's first 200 frames.
  float merge_distance_rel = 0.7f;
  // ... and whose normal is within this angle (degrees). Only surfels below
  // merge_max_source_confidence look for a neighbour to merge into (default: every surfel; with
  // the stable confidence, 6, stable duplicates stayed: fr1/rpy 12% -> 16% duplicates).
  float merge_max_source_confidence = 1e30f;
  float merge_max_normal_angle_deg = 35.0f;
  // Initial capacity of a model's surfel buffer; it doubles when full.
  unsigned initial_capacity = 1u << 19;
  // Most surfels a model keeps after a fusion (0: no cap of its own). The device sets a limit too:
  // a model's buffer holds at most SurfelModel::max_capacity() surfels (maxStorageBufferRange: 2M
  // on lavapipe), and a fusion needs room for one new surfel per pixel beyond the model's count.
  // A model that reaches its limit, or that the device cannot grow (out of memory), has its least
  // confident surfels culled (SurfelModel::make_room) and the run goes on ...
  unsigned max_surfels = 0;
  // ... down to this fraction of the limit, so that culls (each a read-back and an upload of the
  // model) come every few frames rather than every frame. In (0, 1].
  float cull_keep_fraction = 0.9f;
};

}  // namespace cofusion::slam
