#pragma once
// Detections + depth -> instance masks. A box says where an object is and what it is, but not
// which of its pixels are the object; the depth does (after MaskFusion, which cuts its masks at
// geometric edges). For each box, best score first:
//   1. the support plane: RANSAC on the 3D points of a band around the box (the box grown by
//      support_margin on each side, minus the box itself) finds the plane most of the surroundings
//      lie on (the table under a cup, the desk under a keyboard, the floor under a chair). Pixels
//      within support_plane_distance_m of it are "support", never object;
//   2. the seed: among the valid, non-support pixels of the box's central part (seed_fraction of
//      its width and height), the one whose depth is the median of them;
//   3. region growing from the seed over 4-neighbours around the box that are valid, not support,
//      and whose depth differs from the pixel they are reached from by less than
//      max_relative_depth_step x its depth (a depth discontinuity stops the growth, so the
//      background behind the object and things in front of it are cut off). Then the concave cut:
//      where the surface folds concavely (normals turning towards each other by more than
//      fold_angle_deg), the grown region is split into parts, and a part that reaches out of the
//      box (a wall the object leans on, a support that is not one plane, a neighbouring object) is
//      dropped; parts within the box stay (a chair's seat and backrest). Only what lies in the box
//      is kept;
//   4. pixels already claimed by a better-scoring instance stay with it; an instance left with
//      fewer than min_pixels or less than min_box_fraction of its box is dropped.
// People (class 0) come from the person segmenter's probability instead when one is given: the
// box's pixels above person_probability, grown over depth as in step 3 (grow_people_over_depth).
// An instance of another class that lies mostly on the segmenter's pixels is a person
// (person_override_fraction).
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/intrinsics.h"
#include "semantic/detector.h"

namespace cofusion::semantic {

struct InstanceMaskParams {
  // Region growing stops where neighbouring depths differ by more than this fraction of the depth
  // (0.03 = 3 cm at 1 m; Kinect noise is about 0.3-0.5 % of depth at 1-2 m, so object surfaces pass).
  float max_relative_depth_step = 0.03f;
  // A pixel within this distance of the support plane belongs to it (metres).
  float support_plane_distance_m = 0.012f;
  // Band around the box searched for the support plane, as a fraction of the box's width / height
  // added on each side.
  float support_margin = 0.25f;
  // The plane must hold this fraction of the band's valid points to count as a support.
  float support_min_inlier_fraction = 0.3f;
  int ransac_iterations = 200;     // plane hypotheses per box
  int ransac_max_points = 3000;    // band points used (an even subsample when there are more)
  uint32_t seed = 1;               // RANSAC's random generator (runs are deterministic)
  float seed_fraction = 0.3f;      // central part of the box the region grows from (of width/height)
  // The concave cut of step 3: normals are taken from the depth averaged over a square of
  // normal_window_px (pixels) and differences over fold_probe_px to either side; a fold is where
  // the normals fold_probe_px to either side differ by more than fold_angle_deg (degrees; 0 turns
  // the cut off) and face each other. A part of the grown region between folds is dropped when more
  // than fold_part_outside_fraction of its pixels lie outside the box (in the band of step 1).
  float fold_angle_deg = 40.f;
  int fold_probe_px = 4;
  int normal_window_px = 5;
  float fold_part_outside_fraction = 0.25f;
  int min_pixels = 50;             // smaller instances are dropped
  float min_box_fraction = 0.05f;  // instances covering less of their box are dropped
  float person_probability = 0.5f; // person-segmenter threshold (0..1)
  // A box of another class whose mask lies on the person segmenter's pixels for at least this
  // fraction is a person (the detector names a person seen from close up or from behind an
  // elephant or a bed now and then; the segmenter, trained on people only, is the better judge).
  float person_override_fraction = 0.6f;
  // The segmenter (trained on selfies) misses most of the legs: its pixels seed the region growing
  // of step 3 instead of the box's centre, which adds what joins them over continuous depth (cut
  // from the floor and the background like any object).
  bool grow_people_over_depth = true;
  int seed_erosion_px = 5;           // the segmenter's mask is eroded by this radius before seeding
  float seed_depth_window_m = 0.6f;  // growth from a segmenter's seeds stays this close to their median depth
  float min_depth_m = 0.1f;        // depth readings outside [min, max] are invalid
  float max_depth_m = 10.f;
};

struct Instance {
  uint16_t id = 0;  // its value in InstanceMasks::ids, 1..
  int class_id = 0;
  std::string class_name;
  float score = 0;
  cv::Rect2f box_px;
  int pixels = 0;
};

struct InstanceMasks {
  cv::Mat ids;                       // CV_16UC1, 0 = no instance
  std::vector<Instance> instances;   // instances[i].id == i + 1
};

// depth_m: CV_32FC1 metres (0, NaN or out of range = no reading), the size of the detections'
// image; intrinsics for that size. person_probability: CV_32FC1 of the same size, or empty.
// Throws cofusion::Error on mismatched sizes or types.
InstanceMasks instance_masks(const std::vector<Detection>& detections, const cv::Mat& depth_m,
                             const Intrinsics& intrinsics, const InstanceMaskParams& params,
                             const cv::Mat& person_probability = cv::Mat());

}  // namespace cofusion::semantic
