#pragma once
// Semantic instance masks in the pipeline (issue 19): per-pixel instance ids with a class per id,
// from a dataset's masks or from the detector (compute/semantic), given to CoFusion::process()
// with the frame they were made from or a later one (SemanticFrame::age_frames).
//   - Excluded classes (SemanticParams::exclude, default "person"): their pixels are mover pixels
//     in every segmentation mode: never fused into any model, never used to track the camera or
//     an object, never spawning a model.
//   - Segmentation modes (SemanticParams::mode): `motion` (Co-Fusion: models spawn from motion
//     outliers), `semantic` and `both` (MaskFusion-like: recognised instances become models even
//     when they never move) -- see SegmentationMode.
// No OpenCV here: the masks are plain arrays.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/intrinsics.h"

namespace cofusion::slam {

// Instance masks of one frame.
struct SemanticFrame {
  // width*height instance ids, row-major, as the depth image; 0 = no instance.
  std::vector<uint16_t> ids;
  // Class name of each non-zero id ("person", "can", ...). An id without an entry has no class:
  // it is neither excluded nor modelled.
  std::map<uint16_t, std::string> classes;
  // Processed frames between the frame the masks were made from and the frame they are given with
  // (0: made from it; the detector's come from an earlier frame). In semantic/both modes CoFusion
  // carries an older frame's instances to the frame by the camera's tracked motion since
  // (carry_semantic_frame); its excluded pixels stay where the masks saw them.
  int age_frames = 0;
  // Whether these masks were given with an earlier frame already (a detection carried on to the
  // frames until the next one): they still exclude and join, but count no new sighting towards a
  // spawn (SemanticParams::confirm_frames).
  bool repeated = false;
};

enum class SegmentationMode {
  kMotion,    // models spawn from motion only; masks only exclude classes
  kSemantic,  // models from recognised instances only (motion spawns nothing)
  kBoth,      // both: recognised instances become models, motion still separates what moves
};
const char* to_string(SegmentationMode mode);
// "motion", "semantic", "both"; nullopt for anything else.
std::optional<SegmentationMode> parse_segmentation_mode(const std::string& text);

struct SemanticParams {
  SegmentationMode mode = SegmentationMode::kMotion;
  // Classes whose pixels belong to no model (mover pixels) wherever masks are given.
  std::vector<std::string> exclude = {"person"};
  // semantic/both modes: the classes that become models (empty = every class not excluded).
  std::vector<std::string> classes;
  // semantic/both: an instance becomes a model once it was seen in this many consecutive frames
  // (a mask id present with at least min_instance_area_fraction of the image each time) without
  // an existing model covering it.
  int confirm_frames = 2;
  // ... of the image's pixels (with depth) an instance needs to count (1% = 3072 px at 640x480).
  // Smaller objects are tracked poorly from their few pixels: on TUM fr2/desk the detector's cup
  // (0.6-0.8% of the image) spawned a model every 3-4 frames with 0.5%, each dropped when its
  // tracking failed in its first 3 frames.
  double min_instance_area_fraction = 0.01;
  // A mask joins a model when the intersection over union of its pixels (with depth) and the
  // model's labelled footprint in the previous frame is at least this (fraction, 0-1).
  double join_min_iou = 0.3;
  // Excluded pixels are grown by this many pixels (a square of 2r+1 around each): masks lag what
  // they cover (the detector's come from the previous frame) and miss a mover's edge, and a
  // person's rim left in the frame pulls the camera (pixels, at the input's resolution).
  int exclude_margin_px = 8;
  // semantic/both: a model spawned from an instance starts resting (CoFusion: kept where it is in
  // the world, not tracked; the background keeps its surfels and tracks the camera with its
  // pixels, so a room full of chairs and monitors does not starve the camera). It starts moving
  // (tracked on its own, its surfels removed from the background) once the share of its pixels
  // that the background's prediction covers but does not explain exceeds the same share over the
  // rest of the view by more than this (0-1): an absolute bar woke models in every fast turn (TUM
  // fr1/rpy), where the whole prediction is off. An instance that fails the test at its spawn
  // spawns awake.
  double resting_max_unexplained_fraction = 0.5;
  // A resting model that starts moving is tracked at once in the frame it wakes, with that frame's
  // pixels, so that its pose there (and what it fuses) follows what it moved while still held at
  // rest; else it is tracked from the next frame on.
  bool track_woken = true;
};

// Throws cofusion::Error unless `frame` has `pixels` ids.
void check_semantic_frame(const SemanticFrame& frame, size_t pixels);

// Whether `class_name` is one of the excluded classes / a modelled class (SemanticParams::classes;
// never an excluded one).
bool is_excluded_class(const SemanticParams& params, const std::string& class_name);
bool is_modelled_class(const SemanticParams& params, const std::string& class_name);

// An object model's own motion since the masks were made: T_made_current of the points of the
// model with label slot `slot` (its camera-relative motion, as the background's is the camera's).
struct SlotMotion {
  uint8_t slot = 0;
  Eigen::Isometry3d T_made_current = Eigen::Isometry3d::Identity();
};

// `made`'s masks carried to the current frame (a backward warp): each pixel of the current frame
// with depth is moved into the camera the masks were made from (T_made_current, metres) and takes
// the id of the pixel it lands on (nearest); pixels without depth or landing outside that image get
// 0. This follows the camera's motion since. Where `owner` (a slot per pixel, e.g. the previous
// frame's labels; empty: none) names a slot of `object_motions`, the pixel follows that object's
// own motion instead, so the instance of an object that moved stays on it. A mover that is no
// model is not followed (that is what SemanticParams::exclude_margin_px and the motion
// segmentation are for). Classes are copied.
SemanticFrame carry_semantic_frame(const SemanticFrame& made, const float* depth_m, const Intrinsics& intrinsics,
                                   const Eigen::Isometry3d& T_made_current, const std::vector<uint8_t>& owner = {},
                                   const std::vector<SlotMotion>& object_motions = {});

// Per pixel 1 where the pixel's instance has an excluded class, else 0. Returns the count of such
// pixels (0: `excluded` is left empty).
size_t excluded_pixels(const SemanticFrame& frame, const SemanticParams& params, std::vector<uint8_t>& excluded);

// Sets every pixel within `radius_px` (Chebyshev distance) of a non-zero pixel of a row-major
// mask of `width` columns to 1. Returns the count of non-zero pixels after.
size_t grow_mask(std::vector<uint8_t>& mask, int width, int radius_px);

// One instance of a frame's masks whose class is modelled (is_modelled_class).
struct MaskInstance {
  uint16_t id = 0;
  std::string class_name;
  std::vector<size_t> pixels;  // with depth, ascending
};
// The frame's instances of modelled classes with at least min_pixels pixels with depth (depth_m > 0).
std::vector<MaskInstance> modelled_instances(const SemanticFrame& frame, const SemanticParams& params,
                                             const float* depth_m, size_t min_pixels);

// Intersection over union of a pixel set and the pixels of `labels` equal to `label`
// (`label_pixels` of them).
double iou(const std::vector<size_t>& pixels, const std::vector<uint8_t>& labels, uint8_t label, size_t label_pixels);

// Instances no model covers, followed from frame to frame: an instance continues the previous
// frame's candidate it overlaps most when that overlap is at least half of the smaller of the two
// (masks of moving objects shift a little; dataset ids and detector ids need not be stable).
class InstanceCandidates {
 public:
  struct Seen {
    int frames = 1;  // consecutive frames it has been a candidate, this one included
    std::optional<Eigen::Vector3d> previous_centroid;  // the one it continues (camera frame, metres)
  };
  // This frame's uncovered instances with the centroids of their points (camera frame; none
  // without). Forgets the previous frame's candidates.
  std::vector<Seen> update(const std::vector<const MaskInstance*>& uncovered,
                           const std::vector<std::optional<Eigen::Vector3d>>& centroids, size_t image_pixels);

 private:
  std::vector<uint16_t> previous_;    // per pixel: 0 or 1 + index into previous_count_
  std::vector<int> previous_count_;
  std::vector<size_t> previous_size_;
  std::vector<std::optional<Eigen::Vector3d>> previous_centroid_;
};

// A model's recognitions: votes per class.
class ClassVotes {
 public:
  void add(const std::string& class_name, int votes = 1) { votes_[class_name] += votes; }
  void merge(const ClassVotes& other) {
    for (const auto& [name, v] : other.votes_) votes_[name] += v;
  }
  bool empty() const { return votes_.empty(); }
  // The most voted class (ties: the alphabetically first) and its share of all votes; nullopt
  // without votes.
  std::optional<std::pair<std::string, double>> best() const;

 private:
  std::map<std::string, int> votes_;
};

// Sets `value` at every excluded pixel of `labels` (same size). Returns whether any was set.
bool mark_excluded(const std::vector<uint8_t>& excluded, uint8_t value, std::vector<uint8_t>& labels);

}  // namespace cofusion::slam
