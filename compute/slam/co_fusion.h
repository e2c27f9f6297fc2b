#pragma once
// Multi-object dense SLAM (Co-Fusion, Rünz & Agapito 2017): the background and every moving
// object are separate surfel models, each with its own pose, prediction, tracking and fusion.
// Per frame (see docs/design.md, "Frame timeline"):
//   1. upload + preprocess the live frame (GPU, main stream); SLIC superpixels start on the CPU
//      job system at the same time (they need only the frame);
//   2. every active model, on its own stream (its own compute queue where the device has
//      several): predict into the previous view, track with the live pixels it owned in the
//      previous segmentation; once all are tracked, an object whose data do not tell its motion
//      from staying where it is stays (RestParams), and each model computes the per-pixel
//      alignment cost of its new motion;
//   3. motion segmentation on the CPU (unaries from those costs, fully connected CRF over the
//      superpixels, connected components);
//   4. lifecycle: spawn a model from a large outlier region (or re-activate an inactive model
//      that matches it), remove its duplicate from the older models, merge spurious /
//      co-moving models (never two that once moved apart), retire models whose label has been
//      absent for a while;
//   5. every active model fuses the pixels labelled with it (again one stream per model).
// With instance masks (process()'s `semantic`, semantic_masks.h) pixels of excluded classes are
// kept out of steps 2-5 (mover pixels), and in step 4 instances of modelled classes join the
// models they overlap and, in the semantic/both modes, spawn models of their own.
#include <array>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "segmentation/motion_segmentation.h"
#include "slam/camera_check.h"
#include "slam/dense_slam.h"
#include "slam/keyframe_database.h"
#include "slam/motion_kernels.h"
#include "slam/observed_motion.h"
#include "slam/region_rigidity.h"
#include "slam/rolling_shutter.h"
#include "slam/semantic_masks.h"

namespace cofusion::slam {

// How the per-pixel alignment cost of a model (the segmentation's unary input) is formed from
// the motion residuals (motion_kernels.h). Units: metres.
struct MotionCostParams {
  // cost = |point-to-plane distance| + photometric_m * |intensity difference| (intensity in
  // [0, 1]). The paper's cost is purely geometric; a surface sliding along itself (a box pushed
  // over a table) has no geometric residual, but its texture does move.
  float photometric_m = 0.1f;
  // ... at most: when the background's RMS photometric residual after tracking exceeds
  // photometric_reference_rms (intensity in [0, 1]), photometric_m shrinks in proportion, so the
  // photometric part of the cost counts in units of the frame's photometric noise. Measured RMS:
  // 0.007-0.01 on the synthetic scenes, 0.02 on TUM fr2/desk, 0.02-0.10 on fr1/rpy (motion blur).
  // With a fixed 0.1 m fr1/rpy spawned a model from a blurred frame (32 cm camera ATE), with 0.06
  // it stopped using blurred pixels for tracking (4.1 cm); scaled: 2.7 cm. On one_object the
  // sliding box is discovered 6 frames after it starts to move instead of 13 (0.03 m, unscaled).
  double photometric_reference_rms = 0.01;
  // Background only: where the live surface lies this far behind the predicted background, the
  // background's surface there has left (an object moved away and revealed what was behind it).
  // The revealed surface is background, so it costs the background revealed_cost_m rather than
  // the large distance.
  float revealed_margin_m = 0.03f;
  float revealed_cost_m = 0.004f;
  // Costs are capped here (one wrong association must not dominate a superpixel's mean).
  float max_cost_m = 0.1f;
  // Depth noise of structured-light sensors grows with the square of depth (Nguyen et al. 2012:
  // sigma(z) = 1.2 mm + 1.9 mm * (z/m - 0.4)^2 on the optical axis), so the same residual means
  // motion near the sensor and noise far from it. Costs beyond noise_reference_depth_m are scaled
  // by sigma(reference) / sigma(z); nearer ones are left as they are. 0 switches this off.
  float noise_reference_depth_m = 1.0f;
  // A pixel labelled as a model whose own cost there is above this is neither fused into that
  // model nor used to track it in the next frame: it is what the model does not explain (an object
  // starting to move, an occluding hand), and fusing it would make the model absorb the motion.
  // Below the segmentation's outlier crossover (1.5 cm with its defaults): on the two_objects
  // scene 1 cm gives 8 mm camera ATE where 1.5 cm gives 13 mm (the box's pixels, moving slowly
  // before it is discovered, pull the camera less), with no change on the TUM recordings.
  float max_explained_cost_m = 0.01f;
  // A pixel the segmentation gives to a moving object model that has no geometry there, while the
  // background explains it (cost at most max_explained_cost_m), is the background's. Superpixels
  // that span an object's outline and a similarly coloured static surface behind it otherwise hand
  // that surface to the object, which fuses it and is then held back by it (the validation scene's
  // lifted box turned half as fast as it did for six frames). Resting models keep such pixels:
  // they do not move relative to the background.
  bool background_takes_unmodelled = true;
  // An object's residuals are computed only within this many pixels (level 0) of the bounding
  // rectangle of its previous segmentation; beyond it the object counts as having no geometry.
  // Its region can grow this much per frame (fast objects move 10-20 px per frame at 30 Hz),
  // and the cost of every object stays in proportion to its size.
  int object_margin_px = 32;
  // An object turning or lifted shows surfaces its model has not seen. Where such a pixel lies
  // within unseen_surface_reach_px of the object's geometry and at least occluding_margin_m in
  // front of the background's predicted surface (so the background does not explain it either),
  // the object's cost is unseen_surface_cost_m instead of "no geometry": otherwise the
  // background's large cost there makes it an outlier, it is never fused into the object, and the
  // growing unseen part spawns a second model for the same object (five_objects: two of five
  // objects split). Below max_explained_cost_m, so it is fused. The reach keeps a neighbouring
  // object that starts to move out of it.
  float occluding_margin_m = 0.03f;
  float unseen_surface_cost_m = 0.008f;
  int unseen_surface_reach_px = 8;
};

// Model lifecycle (paper section "Addition of New Models", plus merging and re-activation).
struct LifecycleParams {
  // A new model spawns from a connected outlier region covering more than this fraction of the
  // image (paper: 3%) ...
  double spawn_min_area_fraction = 0.03;
  // A region's evidence must last two frames (spawn_min_overlap below): the first frame's region
  // must cover spawn_min_area_fraction, the second's only this smaller fraction (hysteresis: an
  // object that starts slowly makes a region that hovers about the threshold, above it in one
  // frame and below in the next). 0 = both frames need spawn_min_area_fraction.
  double spawn_keep_area_fraction = 0.015;
  // The pixels the segmentation gave the background inside a candidate region (an outlier region
  // that covers spawn_keep_area_fraction, so that it may take part in a spawn, and did not spawn
  // this frame) belong to no model for this frame: the background neither fuses them nor, in the
  // next frame, tracks with them. An object that starts slowly is otherwise absorbed: the
  // background fuses the pixels its motion does not yet push over the outlier cost, fits the
  // object's new place within a frame or two, and its region shrinks or vanishes before it is
  // confirmed. They are not unclaimed pixels (which the camera tracks with when they cover much of
  // the image): the camera would follow the object.
  bool hold_spawn_candidates = true;
  // ... once the background has been fused for this many frames (its model and the camera pose
  // must be stable first, paper section III).
  int warmup_frames = 5;
  // ... and only while the camera moves less than these per frame (and its tracking succeeded and
  // its motion was not refused, CameraCheckParams: a replaced motion is a guess, and against it
  // the static scene looks as if it moved; Bonn crowd spawned a model from a wall that way):
  // during fast camera motion the background's residuals are dominated by blur, rolling shutter
  // and newly revealed surfaces, not by moving objects (TUM fr1/rpy spawned dozens of models).
  double spawn_max_camera_rotation_deg = 0.5;
  double spawn_max_camera_translation_m = 0.02;
  // ... in this frame, and on average over the spawn_steady_frames - 1 frames before it (a camera
  // not lost in any of them; their per-frame rotations and translations summed). Right after a
  // fast turn the background's tracking is still settling: TUM fr1/rpy spawned a model from its
  // static desk one frame after a turn of 1-2.5 degrees per frame, the estimated motion of that
  // frame (0.4 degrees) 0.9 degrees off the true one. On average, because an object that starts
  // to move drags the camera's tracking for one frame before it is segmented (two_objects: 0.66
  // degrees, taken back in the next frame), and a limit for every frame held its spawn back.
  int spawn_steady_frames = 3;
  // ... and only when at least this fraction of the region was a large outlier region in the
  // previous frame too.
  double spawn_min_overlap = 0.5;
  // Evidence over frames for an object under spawn_min_area_fraction (a small one, or one whose
  // motion leaves only part of it an outlier): a region of at least spawn_keep_area_fraction,
  // clear of the image's border (coast_border_px; an object coming into view reaches the paper's
  // size soon), spawns as well, under the same other rules, when it has been a candidate for
  // spawn_persist_frames consecutive frames (each covering at least spawn_min_overlap of it with
  // the previous frame's candidates, the camera steady enough for a spawn in each) and its
  // centroid moved on over them: in the world frame, by at least spawn_persist_min_travel_rel of
  // its distance from the camera (10 mm at 1 m), and in one direction, its net travel at least
  // spawn_persist_min_straightness of the summed steps. A static surface the background fits
  // badly also makes a region frame after frame (TUM fr1/rpy: a far wall while the camera's
  // estimate was off), but its centroid only jitters as the region's outline changes. 0 frames =
  // off (only the paper's size).
  int spawn_persist_frames = 3;
  // ... such regions from this fraction of the image on; 0 = spawn_keep_area_fraction (the
  // smaller of the two counts). A region under spawn_keep_area_fraction spawns only by persisting
  // and travelling, never by the paper's size and its hysteresis, and is not held
  // (hold_spawn_candidates: a small static region the background never fused again would stay a
  // candidate for as long as it is in view). A small object's outlier region
  // hovers near its own size while it starts to move (docs/validation/towards.json's can, 1.1-2.7 %
  // of the image: 1.1 % from 4 frames after its start, 1.5 % only after 16; found 6 frames after
  // its start at 0.01, 18 at 0.015). Parts of people the detector misses persist and travel too:
  // the mover clearance below keeps them from spawning (docs/experiments.md, "Smaller spawn
  // candidates").
  double spawn_persist_min_area_fraction = 0.01;
  // ... such a region under spawn_keep_area_fraction within this many pixels (along a row or a
  // column) of an excluded mover's pixels (a person's mask) is taken for a part of the mover
  // that its mask missed, and does not spawn.
  int spawn_persist_mover_clearance_px = 8;
  double spawn_persist_min_travel_rel = 0.01;
  double spawn_persist_min_straightness = 0.5;
  // A new model's first tracking starts from the region's centroid motion over the last frame
  // when it is at most this long (metres; longer means the regions are not one object's).
  double spawn_max_velocity_guess_m = 0.1;
  // Active models at most, background included (the label map has 30 model slots; each model
  // costs a prediction, a tracking run and a fusion per frame).
  int max_active_models = 8;
  // An object leaving the view whose tracking fails (a sliver at the image's edge, too few pixels
  // for the tracker's minimum) keeps moving by its last motion, as the next frame's guess, for up
  // to coast_frames consecutive failed frames, so its last pixels stay its own; then, and for an
  // object not at the edge, the guess is no motion. At the edge: its labelled pixels' bounding
  // rectangle within coast_border_px of the image's border.
  int coast_frames = 3;
  int coast_border_px = 8;
  // A model whose label is absent this many consecutive frames becomes inactive ...
  int deactivate_after_frames = 10;
  // ... and is kept (inactive) only with at least this many stable surfels, else deleted.
  unsigned min_stable_surfels = 300;
  // Spurious models: a new model that has moved less than these relative to the background
  // after probation_frames is no object (noise or an occlusion edge spawned it) and is merged
  // back into the background. A model spawned by spawn_persist_* counts its travel from where its
  // region's candidate track began: its region was seen moving for frames before (a small can
  // sliding at 4 mm per frame moved 2.4 cm in its 6 frames since the spawn, 3.2 cm since then).
  int probation_frames = 6;
  double static_translation_m = 0.025;
  double static_rotation_deg = 5.0;
  // ... and a new model spawned by motion that moved that far relative to the background stays on
  // probation (and is merged back at its end) while its motion does not show in its pixels
  // (observed_motion.h): a static surface that slides along its own plane (a far wall patch whose
  // plane alone tracks it) travels without changing what the camera sees.
  ObservedMotionParams probation_observed;
  // Two object models whose relative pose changed less than (merge_translation_m,
  // merge_rotation_deg) over the last merge_window_frames while both moved at least
  // (static_translation_m, static_rotation_deg) relative to the background move as one body and
  // are merged (the younger into the older).
  int merge_window_frames = 10;
  double merge_translation_m = 0.01;
  double merge_rotation_deg = 2.0;
  // ... unless their relative pose differed from today's by more than these in some frame both
  // were active: bodies that once moved apart are two objects that move together for a while (the
  // paper's handover: an arm carrying the teddy), not one object split into two models. Tracking
  // noise of one object's two models stays well inside them.
  double merge_history_translation_m = 0.03;
  double merge_history_rotation_deg = 10.0;
  // Duplicate removal at spawn: surfels of the older models (the background, and an object the new
  // one moved with until now) on the new model's pixels that lie in front of or within this
  // fraction of the live depth behind the live surface are removed.
  float duplicate_margin_rel = 0.03f;
  // The background also tracks with unclaimed pixels (outliers that spawned nothing) once they
  // cover more than this fraction of the previous frame: that many outliers mean the camera's
  // tracking is struggling (fast motion), not that objects move, and dropping them would starve
  // it (TUM fr1/rpy). Below it they stay out: an object that starts moving is an outlier before
  // it becomes a model, and tracking the camera with it biases the camera (two_objects scene:
  // 1.3 vs 3.9 cm camera ATE when they are always used).
  double background_tracks_unclaimed_above = 0.15;
  // Outlier regions larger than this fraction of the image spawn nothing: they are the camera's
  // tracking going wrong, not an object.
  double spawn_max_area_fraction = 0.3;
  // Re-activation: an inactive model re-enters when it aligns with a new outlier region with at
  // least this inlier ratio and at most this RMS point-to-plane residual.
  bool reactivate = true;
  double reactivate_min_inlier_ratio = 0.5;
  double reactivate_max_rms_m = 0.01;
  // Object models fail tracking below this inlier ratio (their masked live pixels are few and
  // partly occluded; the background keeps TrackerParams::min_inlier_ratio).
  double object_min_inlier_ratio = 0.05;
  // Object models also track with their outline (TrackerParams::outline_photometric) ...
  bool object_outline_photometric = true;
  // ... also while the image's border cuts them (their working rectangle within coast_border_px of
  // it). Off by default: there the border hides the silhouette on one side, and the outline's pull
  // at the other side's silhouette went unbalanced (five_objects' object 5, a box with sideways
  // stripes cut by the left border, drifted 18.3 mm with it and 2.2 mm without; in view, with
  // both silhouettes, it drifts 2.2 mm with it: docs/experiments.md).
  bool object_outline_at_border = false;
  // While the outline term is off (cut by the border), object models leave the prediction's rim
  // out of their live -> model photometric term (TrackerParams::photometric_skip_rim), as the
  // outline term leaves it out: its fused colours mix the object's with what lay beside it.
  // five_objects' object 5, whose landing where its motion reverses any change tips, drifted 2.8,
  // 9.6, 12.4, 9.4, 2.8 mm RMSE (the scene's noise, seeds 2-5) with it and 10.6, 2.4, 13.0, 16.0,
  // 14.9 without. For every object it was no default: table_placement's box, a narrow face, drifted
  // 57 mm at seed 2 (docs/experiments.md, "The prediction's rim").
  bool object_photometric_skip_rim = true;
  // An object cut by the image's border (coast_border_px) is also tracked from no motion, and
  // that alignment replaces the guess's where its truncated cost is lower by border_still_min_gain
  // of it. The truncated cost: the paired residuals' cost plus, for each live pixel that could meet
  // the model (TrackingResult::inlier_ratio's denominator) but pairs with nothing,
  // border_unpaired_cost times the two alignments' mean cost per residual (9: a residual of 3
  // sigma). Along the side the border hides, an object's cost can be flat, and its constant-
  // velocity guess then carries its model off its own pixels at no cost: five_objects' object 5
  // (sideways stripes, cut by the left border) ran away by 120 mm after its motion reversed (with
  // the camera re-tracked: CameraRetrackParams), while the start from no motion stayed on it,
  // pairing 14-18 % more of its pixels at the same mean cost. Where both starts reach one
  // alignment (every other frame measured) the guess's is kept: taking the start from no motion on
  // ties holds a moving object back (docs/experiments.md). The second start runs the camera's
  // iterations (TrackerParams::iterations_per_level), fewer than an object's: it is there to find
  // another basin. 0 = one start, the guess.
  double border_unpaired_cost = 9.0;
  double border_still_min_gain = 0.05;
  // Object models' photometric weight (TrackerParams::photometric_weight, the paper's lambda; the
  // background keeps its own). lambda = (sigma_icp / sigma_rgb)^2 weighs each term by its noise:
  // 2 mm of depth noise at 1 m (shared/depth_noise.h) against 2.5/255 of intensity noise gives
  // 0.04. The background's 1.0 widens the basin for fast camera turns; an object's motion is
  // guessed from its last one, and its colours are fused from its own tracked poses, so a strong
  // photometric term lets the texture's fused lag hold the geometry back: a weakly textured can
  // turning about its axis drifted 16 mm at 1.0, 5 mm at 0.05 (docs/experiments.md). 0 loses
  // boxes that slide along a face (nothing but texture sees that motion).
  double object_photometric_weight = 0.05;
  // Object models' photometric outlier bound (TrackerParams::max_intensity_diff: a pair whose
  // |I_ref - I_live| / 255 exceeds it is left out). The background's 0.3 by default. Loosened to
  // 0.5, a printed box face's stripe edges (orange and dark, 83 levels or 0.33 apart) count, and
  // the validation box that slides along such a face drifts 0.5-1.2 mm less; but five_objects'
  // object 5, whose landing where its motion reverses any change tips, then drifted 14.4 mm
  // instead of 2.2 (docs/experiments.md, "Objects keep their strong edges").
  double object_max_intensity_diff = 0.3;
  // Object models' robust photometric scale (TrackerParams::photometric_huber_k: residuals beyond
  // this times the previous iteration's RMS residual get Huber weight delta / |r|; 0 = never
  // robust). The background's 1.345 by default. Where only the outline holds an object (a face
  // striped along its motion), its informative residuals are the large ones at the silhouette:
  // at 3 the validation box that turns sideways drifts 3.4 mm at most instead of 5.0, and
  // five_objects' object 5 2.3 mm instead of 7.1 at the scene's noise, but not over noise seeds
  // (2.3-12.2 mm against 3.7-11.5), and one_object, leave_and_return and the validation's
  // crossing box drift 0.6-1.2 mm more (docs/experiments.md, "Objects' robust photometric scale").
  double object_photometric_huber_k = 1.345;
  // Object models' outline term's robust scale relative to their direct term's
  // (TrackerParams::outline_huber_scale).
  double object_outline_huber_scale = 1.0;
  // That ratio holds at this depth; object ICP pairs deeper than it count by their depth noise
  // (TrackerParams::icp_noise_reference_depth_m), so that far, noisy depth does not outweigh the
  // colour (a wall patch at 3.7 m tracked by its plane alone slides along it). 0 = unweighted.
  double object_icp_noise_reference_depth_m = 1.0;
  // Object models' Gauss-Newton iterations per level (TrackerParams::iterations_per_level; the
  // background's default is {1, 4, 6, 10}). Objects are small, so their iterations are cheap (3 ms
  // at full resolution), and they need them: with fewer, each frame stops short of the optimum and
  // the shortfall builds up as drift while an object moves (docs/experiments.md, "Objects that lag behind their motion").
  std::vector<int> object_iterations_per_level = {4, 8, 12, 20};

  // Non-rigid movers (a walking person, a waving arm) are no rigid objects. A new object model is
  // on trial for its first rigidity_trial_frames frames; a frame counts against it when its
  // tracking failed, or when of the pixels the segmentation gave it, less than
  // rigid_min_explained_fraction are explained by its tracked motion (cost at most
  // MotionCostParams::max_explained_cost_m): a rigid body's motion explains all of it but its
  // noise, a body whose parts move differently leaves the rest unexplained. At
  // rigidity_max_failures such frames the model is dropped (its surfels discarded) and its pixels
  // become a mover region.
  int rigidity_trial_frames = 8;
  int rigidity_max_failures = 3;
  double rigid_min_explained_fraction = 0.7;
  // Mover regions are followed from frame to frame: an outlier region (connected, any size) that
  // overlaps the previous frame's mover pixels with at least this fraction of its own pixels is the
  // same mover, moved on. Mover pixels belong to no model: nothing fuses them, nothing tracks with
  // them (not even the background when outliers are many), and they spawn no model. A mover that
  // stops moving is explained by the background again and leaves the regions.
  double mover_min_overlap = 0.3;
  // A region spawns a model only when it moved as one rigid body since the previous frame
  // (region_rigidity.h): a person entering the view, before the detector or the person segmenter
  // sees them, is a region but no rigid body. A region that fails stays a candidate.
  RegionRigidityParams spawn_rigidity;
  // Evidence over frames for an object that starts slowly. While its displacement is still below
  // the outlier crossover, the background's cost over it rises from frame to frame; over a static
  // surface the background fits badly it is raised but steady. Superpixels whose mean background
  // cost is at least rising_min_cost_m form regions (4-connected, outlier pixels included). A
  // region of at least rising_min_area_fraction of the image whose mean cost (over its pixels with
  // a cost in all three frames) rose by at least rising_min_step_m in each of the last two frames,
  // and is at most rising_max_cost_m (above it the segmentation separates the motion by itself: a
  // person walking in), lends its background pixels whose own cost is at least rising_min_cost_m
  // to the outlier regions that spawn models, while the camera is steady enough for a spawn. The
  // usual rules for a spawn follow (two frames running, rigid motion). Only spawning sees them:
  // fusion and tracking use the segmentation as it is. rising_min_step_m 0 = off.
  double rising_min_cost_m = 0.006;
  double rising_min_step_m = 0.002;
  double rising_min_area_fraction = 0.01;
  double rising_max_cost_m = 0.03;
  // Evidence from the previous frame for a surface that slides along itself (a box pushed over a
  // table: its top and the faces along its path). There the background's cost stays low (no
  // point-to-plane residual, and fusion keeps averaging the moving texture into the background),
  // but the image differs from the previous frame where the camera's motion puts each pixel. A
  // background pixel differs where that intensity difference (after the frames' exposure ratio) is
  // above slide_min_intensity and above what a shift of slide_min_shift_px along the previous
  // image's gradient explains (the camera's pose error, noise), at a point the previous frame saw
  // at that depth. A superpixel with at least slide_min_fraction of its tested pixels differing
  // lends its background pixels to the outlier regions that spawn models, but only to a region
  // that holds outlier or rising pixels of its own, while the camera is steady enough for a spawn.
  // Only spawning sees them, as rising pixels. slide_min_shift_px 0 = off.
  double slide_min_shift_px = 1.5;
  double slide_min_intensity = 0.04;  // grey level in [0, 1]
  double slide_min_fraction = 0.2;
};

// Camera tracking loss and relocalisation. A frame whose camera tracking fails is lost: its pose is
// not updated and nothing is fused. Every following frame is relocalised against the background
// model until one succeeds: tracked (with all its pixels) from the last tracked pose, from the pose
// the previous frame's closest attempt reached (the camera moves on while lost) and from the poses
// of the keyframes that look most like it (KeyframeDatabase); the best alignment that passes the
// thresholds below recovers the camera, and the pipeline resumes from the next frame.
struct RelocalisationParams {
  KeyframeParams keyframes;
  // Keyframes tried besides the last tracked pose.
  int candidate_keyframes = 3;
  // A relocalisation is accepted when its alignment is about as good as the camera's tracking was
  // before the loss (the median over the last recent_frames tracked frames; sensors, depths and
  // scenes differ too much for absolute thresholds): an inlier ratio (TrackingResult::inlier_ratio)
  // of at least min_inlier_ratio_rel times that median and an RMS point-to-plane residual of at
  // most max_rms_rel times it. Stricter than tracking's own failure rules: an alignment from a
  // wrong start can converge to a wrong but self-consistent pose.
  // The relocalisation's RMS is higher than tracking's: the prediction holds only stable surfels
  // (the recent unconfirmed ones have aged out while lost) and the live frame is not masked.
  int recent_frames = 30;
  double min_inlier_ratio_rel = 0.9;
  double max_rms_rel = 1.5;
  // Tracking runs per start, each from where the previous one got to (from a start 30 cm away one
  // run has not converged).
  int tracking_passes = 3;
  // No new model spawns for this many frames after a recovery (the background's residuals must
  // settle first, as at the start: LifecycleParams::warmup_frames).
  int settle_frames = 5;
};

// Objects at rest. A box seen edge-on as one striped face constrains few directions of its motion:
// tracked from the constant-velocity guess, it keeps whatever velocity those directions had and
// wanders once it has been put down (table_placement: its model turned by 180 degrees on the
// table). After tracking, each object's motion is compared with staying where it is in the world
// (moving with the camera only) on the same pixels: where staying explains them as well, within
// the noise, the object stays. A choice between two explanations of the data, not a prior on the
// pose: wherever the data tell them apart, they decide.
struct RestParams {
  bool prefer_rest = true;
  // Rest is taken when its mean cost per residual (point-to-plane squared plus lambda times
  // photometric squared, at full resolution) is at most (1 + this) times the tracked motion's ...
  // The tracked pose fits six more parameters, which lowers its cost a little; a real motion d
  // along a direction the data constrain raises rest's by about (d / noise)^2, so 0.1 lets
  // through about a third of the depth noise per frame, which the next frames then catch. Frame
  // to frame the tracked pose's cost varies by 10-20% on a model still being fused: 0.03 kept the
  // table_placement box still in only half of its frames at rest.
  double max_cost_increase = 0.1;
  // ... and it keeps at least this fraction of the tracked motion's ICP correspondences.
  double min_correspondence_fraction = 0.98;
};

// The camera tracked again after the segmentation, with this frame's labels, when the
// segmentation took a surge of the pixels the camera tracked with away from the background. An
// object that starts to move is still the background's in the previous frame's labels, which mask
// the camera's tracking, and pulls the camera along until it is segmented; every model's world
// pose in that frame, and the anchor of every model found in it, carries the camera's error (the
// drift `eval objects` measures while the model's pose in the camera is right). Taken pixels count
// in connected regions of at least min_region_fraction of the image: scattered pixels at depth
// edges leave the background in every frame. A surge: at least min_taken_fraction of the image and
// surge_factor times the median of the baseline_frames frames before it (real depth loses regions
// of a few percent to noise in every frame), while the camera is steady enough for a spawn (in fast
// motion the segmentation takes blur and newly seen surfaces away). A new pose that moves the
// camera more than max_correction_* from the first is not taken. Measured (docs/experiments.md,
// "Where object drift comes from" and the entry after it): five_objects' camera 1.7 -> 1.35 mm and
// its objects 1-3 drifting 2.2-3.9 mm at most instead of 3.9-6.4 at five noise seeds;
// two_boxes_slow's boxes 3.6 and 5.0 mm instead of 7.4 and 5.8; TUM unchanged (no frame re-tracked);
// Bonn crowd 2.80 cm (2.77 without), `--segmentation both` 2.91 cm (2.82). It waited for objects
// cut by the border to take a second start (LifecycleParams::border_unpaired_cost): before that
// five_objects' object 5 ran away with it. 0 = off.
struct CameraRetrackParams {
  double min_taken_fraction = 0.01;  // 0 = off
  double min_region_fraction = 0.003;
  double surge_factor = 2.0;
  int baseline_frames = 10;
  double max_correction_m = 0.02;
  double max_correction_deg = 1.0;
};

struct CoFusionParams {
  SlamParams slam;
  segmentation::MotionSegmentationParams segmentation;
  MotionCostParams costs;
  LifecycleParams lifecycle;
  RestParams rest;
  RelocalisationParams relocalisation;
  CameraCheckParams camera_check;
  CameraRetrackParams retrack;
  // false: background only (no segmentation, no new models), as an ElasticFusion-class system.
  bool motion_segmentation = true;
  // Instance masks (process()'s `semantic`): excluded classes, segmentation mode.
  SemanticParams semantic;
  // Host work that needs only the frame on CPU jobs beside the GPU's work (CoFusion's
  // overlap_host_work_): kAuto = on a real GPU, not where the device is the CPU itself (lavapipe).
  // Results are the same either way.
  enum class HostOverlap { kAuto, kOn, kOff } host_overlap = HostOverlap::kAuto;
};

// (frame, T_world_model) per frame, ascending frames.
using PoseHistory = std::vector<std::pair<int, Eigen::Isometry3d>>;

// Whether the relative pose of two models (a's pose inverse times b's) stayed within
// (max_translation_m, max_rotation_deg) of T_a_b in every frame both have a pose for. Two models
// of one rigid body keep their relative pose; two bodies that once moved apart do not (merging).
bool relative_pose_held(const PoseHistory& a, const PoseHistory& b, const Eigen::Isometry3d& T_a_b,
                        double max_translation_m, double max_rotation_deg);

enum class ModelState { kActive, kInactive };
const char* to_string(ModelState state);

// One model's state after a frame.
struct ModelStatus {
  int id = 0;  // 0 = background
  ModelState state = ModelState::kActive;
  Eigen::Isometry3d T_world_model = Eigen::Isometry3d::Identity();
  unsigned surfels = 0;
  int first_frame = 0;  // spawned
  int last_frame = 0;   // last frame with pixels labelled as this model
  int pixels = 0;       // labelled pixels this frame
  bool tracked = false;  // tracked this frame (false the frame it spawned)
  TrackingResult tracking;
};

// The camera's tracking this frame: tracked; lost (tracking failed, or relocalisation has not
// succeeded yet: pose not updated, nothing fused); recovered (relocalised this frame); refused
// (the tracked motion contradicted the previous frame's depth, or tracking failed where a
// stand-in still fits it, CameraCheckParams: the better of the slowed constant-velocity guess and
// no motion is taken, nothing is fused into the background).
enum class CameraState { kTracking, kLost, kRecovered, kRefused };
const char* to_string(CameraState state);

struct CoFusionFrame {
  int frame = 0;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  CameraState camera_state = CameraState::kTracking;
  TrackingResult camera_tracking;  // the background's tracking (default on the first frame)
  bool camera_retracked = false;   // tracked again after the segmentation (CameraRetrackParams)
  std::vector<ModelStatus> active;  // after this frame's lifecycle changes; background first
  std::vector<std::string> events;  // one line each: spawned, merged, deactivated, re-activated, re-found, deleted
  // Per pixel: model id, 0xFFFF = no model (unassigned, excluded, or no depth). Pixels without
  // depth take the model of most of their superpixel's pixels with depth (motion segmentation);
  // pixels the segmentation gave to a model whose motion does not explain them are that model's.
  std::vector<uint16_t> labels;
  std::vector<std::pair<std::string, double>> stage_ms;  // wall-clock per stage, in order
  // CPU segmentation: superpixels (run while the GPU tracks) and the rest (after tracking).
  double superpixels_ms = 0;
  double superpixels_overlap_ms = 0;  // of superpixels_ms, the part that ran while GPU work was in flight
  double crf_nodes_ms = 0;            // of superpixels_ms, the CRF's nodes and kernels (0 where built in line: host_overlap)
  double segment_ms = 0;
  // segment_ms by part, in order: the models' costs, the segmenter's unaries, CRF and connected
  // components, the rising background cost and the change since the previous frame (side by
  // side), the lifecycle.
  std::vector<std::pair<std::string, double>> segment_parts_ms;
  // The lifecycle's part of segment_parts_ms by step, in order: the segmentation's slots (and the
  // rigidity trial), merges, the spawn plan, the pixels per slot, instances and resting models, the
  // label upload, spawns and presence.
  std::vector<std::pair<std::string, double>> lifecycle_parts_ms;
};

// A model for export and display.
struct ModelSnapshot {
  int id = 0;
  ModelState state = ModelState::kActive;
  const SurfelModel* model = nullptr;
  int first_frame = 0, last_frame = 0;
  // Semantic class: "background" for id 0, the class it was most often recognised as by instance
  // masks (ModelClassVotes), else "object"; confidence = that class's share of its recognitions
  // (0 when never recognised).
  std::string class_name;
  double class_confidence = 0.0;
  // (frame, T_world_model) in the frames it was active and its tracking did not fail (the frame
  // it spawned or re-activated included): a failed tracking only guesses the pose.
  PoseHistory trajectory;
};

// Thread safety: one thread calls process() at a time; it uses its own worker threads inside.
class CoFusion {
 public:
  CoFusion(gpu::Context& ctx, const Intrinsics& intrinsics, const CoFusionParams& params);
  ~CoFusion();
  CoFusion(const CoFusion&) = delete;
  CoFusion& operator=(const CoFusion&) = delete;

  // Processes the next frame: `depth_m` width*height floats in metres (0/NaN = no reading), `rgb`
  // width*height*3 bytes, `semantic` the frame's instance masks when there are any (made from this
  // frame or, SemanticFrame::age_frames, from an earlier one: then, in semantic/both modes, its
  // instances are carried to this frame by the camera's tracked motion since; see
  // semantic_masks.h): pixels of excluded classes are mover pixels (no fusion, no tracking, no
  // spawning). Masks need motion_segmentation (the label map that keeps them out).
  CoFusionFrame process(const float* depth_m, const uint8_t* rgb, const SemanticFrame* semantic = nullptr);
  // The input skipped frames since the last process() (unreadable, or without depth): the camera
  // may have moved further than tracking from the last pose reaches, so the next frame is
  // relocalised (from the last pose first, then the keyframes' PnP poses), as after a loss.
  void note_gap() {
    if (frame_ > 0) lost_ = true;
  }
  // The next frame's timestamp, seconds (an input without them: frames are
  // RollingShutterParams::nominal_frame_interval_s apart), and its colour camera's readout time
  // as the input gives it (RollingShutterParams::colour_readout_s, which overrides it).
  void note_frame_time(double t_s, double input_colour_readout_s) {
    unwarper_.note_frame_time(t_s, input_colour_readout_s);
  }

  // Active and inactive models (background first, then by id).
  std::vector<ModelSnapshot> models() const;
  // The main stream (uploads, preprocessing, read-backs for export and display).
  gpu::Stream& stream() { return main_stream_; }
  int frames_processed() const { return frame_; }
  const CoFusionParams& params() const { return params_; }

 private:
  struct Model;
  Model& create_model(int slot, const Eigen::Isometry3d& T_world_model);
  void predict_model(Model& m, const gpu::TimelinePoint& preprocessed);
  uint32_t tracked_slot_mask(const Model& m, uint32_t resting) const;
  TrackingJob tracking_job(Model& m, const Eigen::Isometry3d& guess);
  // Tracks the models together (track_together), each with its own live pixels.
  void track(const std::vector<Model*>& models);
  bool cut_by_border(const Model& m) const;
  void choose_object_terms(Model& m);
  void track_second_starts(const std::vector<Model*>& models, std::vector<TrackingJob>& jobs);
  bool second_start_wins(const Model& m, const TrackingResult& moved, const TrackingResult& still) const;
  void settle_models(const std::vector<Model*>& models, const Eigen::Isometry3d& camera_motion);
  void rest_if_still_fits(Model& m, const Eigen::Isometry3d& camera_motion, const LinearSystemSums& still);
  void compute_residuals(const std::vector<Model*>& models);
  // Fuses the pixels of m's slot and of `also_slots` (bit s for slot s).
  void fuse_model(Model& m, const std::vector<int>& duplicate_slots, const PixelRect& fuse_rect, uint32_t also_slots = 0);
  void model_costs(const Model& m, const float* depth_m, std::vector<float>& costs) const;
  // The steps of process(), in order.
  std::vector<uint8_t> begin_semantic_frame(const SemanticFrame* semantic);
  const SemanticFrame* carried_to_this_frame(const SemanticFrame& semantic, const float* depth_m);
  void set_work_rects(const std::vector<Model*>& active);
  CameraState track_or_relocalise(const std::vector<Model*>& active, const float* depth_m, const uint8_t* rgb,
                                  const FrameEncoding& encoding, const gpu::TimelinePoint& preprocessed, CoFusionFrame& out,
                                  const std::function<void(const char*)>& stage);
  template <typename Work>
  static void for_each_model(const std::vector<Model*>& models, const Work& work);
  CameraState track_models(const std::vector<Model*>& active, const float* depth_m, std::string& refusal,
                           const std::function<void(const char*)>& stage);
  CameraFits camera_fits(const Model& bg, const float* depth_m) const;
  void retry_camera_tracking(Model& bg, const float* depth_m, std::optional<CameraFits>& fits);
  bool tracked_poses_agree(const Model& bg, const float* depth_m, const CameraFits& f);
  std::string check_camera_motion(Model& bg, const float* depth_m, const std::optional<CameraFits>& fits);
  double keyframe_pull_gain(const std::vector<uint8_t>& excluded) const;
  void pull_towards_keyframes(Model& bg, const float* depth_m) const;
  std::optional<KeyframePose> frame_keyframe_pose(const float* depth_m) const;
  std::vector<float> depth_outside_excluded(const float* depth_m) const;
  std::optional<KeyframePose> keyframe_camera_pose(const float* depth_m) const;
  std::string take_keyframe_pose(Model& bg, const CameraFits& f, const Eigen::Isometry3d& T_world_features);
  Eigen::Isometry3d camera_pose_after(const Eigen::Isometry3d& camera_motion) const;
  void update_poses(const std::vector<Model*>& active, CoFusionFrame& out);
  // CameraRetrackParams: `tracked_slots` are the labels the camera tracked with.
  bool retrack_surge(const std::vector<uint8_t>& tracked_slots, int background_slot, uint32_t resting);
  void retrack_camera(const std::vector<uint8_t>& tracked_slots, CoFusionFrame& out);
  void track_woken(const std::vector<Model*>& were_resting, CoFusionFrame& out);
  void segment(const segmentation::Superpixels& superpixels, const float* depth_m, const uint8_t* rgb,
               const std::vector<uint8_t>& excluded, std::vector<Model*>& active, CoFusionFrame& out,
               std::vector<int>& spawned_slots);
  void label_all_background(const float* depth_m, const std::vector<uint8_t>& excluded);
  void fuse_models(const std::vector<int>& spawned_slots);
  void keep_frame(CameraState camera, const FrameEncoding& encoding, const float* depth_m, const uint8_t* rgb,
                  const segmentation::Superpixels* superpixels, const std::vector<uint8_t>& excluded, CoFusionFrame& out);
  void finish_frame(CameraState camera, CoFusionFrame& out);
  // The model lifecycle (lifecycle.cpp).
  std::vector<uint8_t> apply_lifecycle(const segmentation::SegmentationResult& seg,
                                       const std::vector<std::vector<float>>& costs, const float* depth_m,
                                       const uint8_t* rgb, std::vector<Model*>& order, CoFusionFrame& out,
                                       std::vector<int>& spawned_slots);
  // This frame's outlier regions (pixel lists, largest first) and those of them that spawn.
  struct SpawnPlan {
    struct Spawn {
      size_t region;  // index into regions
      int slot;       // the free slot it takes
      std::optional<Eigen::Vector3d> centroid, previous_centroid;  // camera frame, this and last frame
      std::optional<double> rigid_fraction;  // LifecycleParams::spawn_rigidity's measure, when it ran
      // Spawned by spawn_persist_* (not the paper's size): the world centroid of its region when its
      // candidate track began; the new model's probation counts the travel since.
      std::optional<Eigen::Vector3d> track_start_world;
    };
    std::vector<std::vector<size_t>> regions;
    std::vector<PixelRect> region_rects;  // the regions' bounding rectangles
    std::vector<Spawn> spawns;
    std::vector<size_t> held;  // regions whose background pixels are held (hold_spawn_candidates)
  };
  std::vector<uint8_t> slots_from_segmentation(const segmentation::SegmentationResult& seg,
                                               const std::vector<std::vector<float>>& costs, const float* depth_m,
                                               const std::vector<Model*>& order, CoFusionFrame& out);
  void relabel(std::vector<uint8_t>& slots, int from, int to);
  void merge_static_newcomers(const std::vector<Model*>& order, const float* depth_m, const uint8_t* rgb,
                              std::vector<uint8_t>& slots, CoFusionFrame& out);
  bool motion_observed(const Model& m, const std::vector<uint8_t>& slots, const float* depth_m,
                       const uint8_t* rgb) const;
  void merge_comoving(const std::vector<Model*>& order, std::vector<uint8_t>& slots, CoFusionFrame& out);
  static void hold_candidates(const SpawnPlan& plan, int background_slot, std::vector<uint8_t>& slots,
                              std::vector<int>& slot_pixels);
  std::vector<uint8_t> rising_background(const segmentation::Superpixels& superpixels,
                                         const std::vector<float>& background_costs, const std::vector<uint8_t>& labels,
                                         uint8_t outlier);
  struct PreviousSamples {
    std::vector<float> intensity, gradient;  // per pixel; intensity -1 = not seen there
  };
  // Whether this frame's camera motion can be checked against the previous frame's image
  // (LifecycleParams::slide_*): there is one, and it was tracked.
  bool can_sample_previous() const;
  PreviousSamples sample_previous(const float* depth_m, const Eigen::Isometry3d& T_previous_current) const;
  float exposure_gain(const PreviousSamples& s, const uint8_t* rgb, const std::vector<uint8_t>& labels) const;
  std::vector<uint8_t> changed_since_previous(const segmentation::Superpixels& superpixels, const float* depth_m,
                                              const uint8_t* rgb, const std::vector<uint8_t>& labels) const;
  std::vector<uint8_t> rising_regions(const std::vector<uint8_t>& raised,
                                      const std::array<const std::vector<float>*, 3>& costs,
                                      const std::vector<uint8_t>& labels);
  std::vector<std::vector<size_t>> outlier_regions(const segmentation::SegmentationResult& seg, uint8_t outlier,
                                                   std::vector<uint8_t>& slots, std::vector<PixelRect>& rects);
  std::optional<Eigen::Vector3d> region_centroid(const std::vector<size_t>& pixels, const float* depth_m) const;
  SpawnPlan plan_spawns(const segmentation::SegmentationResult& seg, const float* depth_m, uint8_t outlier,
                        const Model& bg, std::vector<uint8_t>& slots, CoFusionFrame& out);
  bool spawn_camera_steady(const Model& bg) const;
  bool steady_motion(const Eigen::Isometry3d& motion) const;
  bool camera_was_steady() const;
  std::optional<double> rigid_fraction(const std::vector<size_t>& pixels, const float* depth_m,
                                       const std::optional<Eigen::Vector3d>& centroid,
                                       const std::optional<Eigen::Vector3d>& previous_centroid) const;
  void spawn_or_reactivate(const SpawnPlan::Spawn& sp, const std::vector<size_t>& pixels, const float* depth_m,
                           const uint8_t* rgb, const std::vector<int>& slot_pixels, CoFusionFrame& out,
                           std::vector<int>& spawned_slots);
  void update_presence(const std::vector<int>& slot_pixels, CoFusionFrame& out);
  bool try_reactivate(Model& m, int slot, const Eigen::Vector3d& centroid_camera);
  bool relocalise(Model& bg, const FrameEncoding& encoding, const FrameFeatures& features);
  const uint8_t* without_rolling_shutter(const uint8_t* rgb);
  void hold_still(const std::vector<Model*>& active, const std::string& why);
  std::vector<Model*> live_models() const;  // the active models, background first
  static uint32_t resting_slots(const std::vector<Model*>& models);  // bit s: a resting model's slot s
  std::vector<char> mark_movers(uint8_t outlier, std::vector<uint8_t>& slots) const;
  void apply_instances(std::vector<uint8_t>& slots, std::vector<int>& slot_pixels, uint32_t& taken, const float* depth_m,
                       const std::vector<float>& background_costs, CoFusionFrame& out, std::vector<int>& spawned_slots);
  void spawn_instances(const std::vector<const MaskInstance*>& uncovered, std::vector<uint8_t>& slots,
                       std::vector<int>& slot_pixels, uint32_t& taken, const float* depth_m,
                       const std::vector<float>& background_costs, CoFusionFrame& out, std::vector<int>& spawned_slots);
  bool reactivate_at_instance(const MaskInstance& instance, const Eigen::Vector3d& centroid_world, int slot,
                              CoFusionFrame& out);
  void wake_resting(const std::vector<float>& background_costs, const std::vector<uint8_t>& slots, CoFusionFrame& out,
                    std::vector<int>& spawned_slots);
  void drop_nonrigid(const std::vector<Model*>& order, const std::vector<uint8_t>& seg_labels,
                     const std::vector<int>& labelled, const std::vector<int>& explained,
                     std::vector<uint8_t>& slots, CoFusionFrame& out);
  void merge_into(Model& keep, Model& gone, CoFusionFrame& out, const std::string& why);
  void report_cull(Model& m, CoFusionFrame& out);
  void retire(Model& m, CoFusionFrame& out);
  void upload_labels(const std::vector<uint8_t>& slots);
  int free_slot(uint32_t taken = 0) const;  // a slot no active model (nor `taken`, a bit mask) uses

  gpu::Context& ctx_;
  // Whether host work that needs only the frame runs on CPU jobs beside the GPU's work (the CRF's
  // nodes with the superpixels, the previous-frame samples with the residuals, the frame's
  // outputs with the fusion); by default not where the "GPU" is the same CPU (lavapipe): there
  // the jobs take the driver's cores mid-dispatch, and frames with 6 models were 15-18 % slower.
  const bool overlap_host_work_;
  Intrinsics intrinsics_;
  CoFusionParams params_;
  // The frame's preprocessing: the slam parameters' plus what the object trackers need.
  kernels::PreprocessParams preprocess_;
  gpu::Stream main_stream_;
  kernels::Preprocessor preprocessor_;
  SurfelPipelines surfels_;
  MotionKernels motion_;
  segmentation::MotionSegmenter segmenter_;
  kernels::FramePyramid live_;
  // The previous frame's depth (kept when CameraCheckParams or LifecycleParams::spawn_rigidity is
  // on) and the depth_fit of the camera motion the last checked frame took.
  std::vector<float> previous_depth_m_;
  // This frame's colour and excluded pixels (process() only): for the keyframes' pose of the camera.
  const uint8_t* frame_rgb_ = nullptr;
  // Resamples each frame's colour to its middle row's pose (RollingShutterParams) and holds it.
  ColourUnwarper unwarper_;
  const std::vector<uint8_t>* frame_excluded_ = nullptr;
  // This frame's keyframes' pose where a CPU job computes it while the GPU tracks (process() only;
  // empty: computed where it is needed).
  std::function<std::optional<KeyframePose>()> frame_keyframe_pose_;
  double frame_pull_gain_ = 0;  // CameraCheckParams::keyframe_pull_gain's fraction this frame
  double last_camera_fit_ = 0;
  // The last frame's refused tracked pose (T_world_camera) and how many refused frames in a row
  // agreed with the one before (CameraCheckParams::agreeing_frames).
  std::optional<Eigen::Isometry3d> refused_T_world_tracked_;
  int agreeing_refusals_ = 0;
  gpu::BufferPtr labels_;             // uint per pixel: model slot of the previous segmentation
  gpu::TimelinePoint labels_uploaded_;  // where the GPU has the last labels upload_labels() gave it
  std::vector<uint8_t> slots_;        // host copy of labels_ (255 = none)
  // Per pixel, the slot of the model the segmentation gave it to where that model's motion does not
  // explain it (its cost is over MotionCostParams::max_explained_cost_m: a texture edge the fused
  // model shows blurred, say), else kNoSlot. Such a pixel is neither fused nor tracked with (its
  // slot is kNoSlot) but is the model's in the reported segmentation (CoFusionFrame::labels).
  std::vector<uint8_t> unexplained_slots_;
  double unclaimed_fraction_ = 0;  // of the previous frame's pixels
  // This frame's share of pixels (not movers') that the background's prediction covers but does not
  // explain: the bar a resting model's own share is measured against (SemanticParams).
  double scene_unexplained_share_ = 0;
  // A candidate region followed over consecutive steady frames (LifecycleParams::spawn_persist_*):
  // how many, and its world centroid's path over them.
  struct CandidateTrack {
    int frames = 0;
    std::optional<Eigen::Vector3d> first_world, last_world;  // centroids, world frame
    double path_m = 0;                                        // summed centroid steps
    // The track continued by this frame's region (centroid in the camera frame).
    CandidateTrack continued(const std::optional<Eigen::Vector3d>& world_centroid) const;
  };
  struct SpawnCandidate {
    std::optional<Eigen::Vector3d> centroid;  // of its live points, camera frame; none without depth
    bool large = false;                       // it covered spawn_min_area_fraction
    CandidateTrack track;                     // its frames as a candidate (spawn_persist_*)
  };
  bool persisted_and_moved(const CandidateTrack& track, const PixelRect& rect) const;
  // LifecycleParams::spawn_keep_area_fraction (spawn_min_area_fraction where that is 0): the
  // smallest region that may confirm a spawn by the paper's size.
  double keep_area_fraction() const;
  // Whether a pixel of `pixels` lies within reach_px (along its row or column) of a kMoverSlot pixel.
  bool near_mover(const std::vector<size_t>& pixels, const std::vector<uint8_t>& slots, int reach_px) const;
  // The smallest outlier region that is a spawn candidate (spawn_persist_min_area_fraction where
  // set, else keep_area_fraction()).
  double candidate_min_area_fraction() const;
  // The previous frame's outlier regions (outlier_regions) that did not spawn: per pixel 0 = none,
  // k = the k-th, described by entry k - 1.
  std::vector<uint8_t> spawn_candidate_;
  std::vector<SpawnCandidate> spawn_candidates_;
  // The background's per-pixel costs of the last two frames (frame number, costs; newest last)
  // and this frame's rising pixels (LifecycleParams::rising_min_step_m; empty = none).
  std::deque<std::pair<int, std::vector<float>>> background_cost_history_;
  std::vector<uint8_t> rising_;
  std::deque<double> retrack_taken_;  // CameraRetrackParams: the taken share of the last frames
  segmentation::ComponentLabelling retrack_components_;  // scratch of retrack_surge
  std::vector<uint8_t> changed_;  // this frame's changed pixels (LifecycleParams::slide_*; empty = none)
  std::optional<PreviousSamples> previous_samples_;
  std::vector<float> previous_intensity_;  // the previous frame's grey levels in [0, 1]
  segmentation::ComponentLabelling rising_components_;
  segmentation::ComponentLabelling components_;  // scratch of the outlier-region search
  std::vector<std::unique_ptr<Model>> models_;  // active and inactive
  // Tracking loss: lost_ from a failed camera tracking until a relocalisation succeeds;
  // T_world_camera_ stays the last tracked pose meanwhile.
  KeyframeDatabase keyframes_;
  bool lost_ = false;
  // While lost: the previous frame's relocalisation attempt that came closest (RMS m, T_world_live).
  std::optional<std::pair<double, Eigen::Isometry3d>> closest_attempt_;
  std::vector<std::pair<double, double>> recent_tracking_;  // (inlier ratio, RMS m) of tracked frames, oldest first
  int last_recovery_frame_ = -1000000;
  // This frame's instance masks (null without), and the instances no model covers yet.
  const SemanticFrame* semantic_ = nullptr;
  SemanticFrame carried_semantic_;  // older masks carried to this frame (SemanticFrame::age_frames)
  // T_world_camera of the last processed frames, oldest first (none where the camera was lost):
  // what older masks are carried from. Masks older than this many frames are taken as they are.
  static constexpr size_t kCameraHistoryFrames = 16;
  std::deque<std::optional<Eigen::Isometry3d>> camera_history_;
  uint32_t resting_slots_ = 0;  // this frame's label slots of resting models (Model::resting)
  InstanceCandidates instance_candidates_;
  int next_id_ = 1;
  int frame_ = 0;
  Eigen::Isometry3d T_world_camera_ = Eigen::Isometry3d::Identity();
};

}  // namespace cofusion::slam
