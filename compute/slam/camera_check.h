#pragma once
// A check of the camera's tracked motion against the previous frame's depth. Frame-to-model
// tracking can converge to a wrong pose when movers cover most of the view and the little
// background left is far and weakly constrained (Bonn crowd: the pose jumped 20-50 cm while the
// camera moved 2 mm). The previous frame is a measurement, not a model: at video rate almost every
// pixel of it, people included, is where the true motion puts the next frame's pixels, so a
// tracked motion that explains far fewer of them than the constant-velocity guess (or no motion)
// does is refused, and replaced by a slowed constant-velocity guess (or no motion).
#include <Eigen/Geometry>

#include "common/intrinsics.h"

namespace cofusion::slam {

struct CameraCheckParams {
  bool enabled = true;
  // Every step_px-th pixel in x and y takes part (4: 4,800 of 640x480's pixels).
  int step_px = 4;
  // A live pixel fits where its point, moved into the previous camera, lands on a pixel whose depth
  // is within tolerance_rel * depth + tolerance_m of it (axial noise is about 1% of depth at 3 m
  // for Kinect-class sensors; the margin also absorbs a pixel's rounding).
  double tolerance_rel = 0.02;
  double tolerance_m = 0.01;
  // The tracked motion is refused when its fit is below this fraction of the better of the
  // constant-velocity guess's and no motion's. Correct tracking fits at least as well as either
  // (within a few percent of noise; the guess is off by the frame's change of velocity); the jumps
  // fit a third or less of what the guess does.
  double min_fit_ratio = 0.8;
  // The camera (the background model) is tracked with the photometric term weighted by
  // photometric_weight instead of TrackerParams::photometric_weight (which objects keep; 0 = the
  // same). When that tracking fails or its motion is refused, the camera is tracked once more from
  // the same guess with retry_photometric_weight (0 = no second tracking), and the result that
  // fits the previous frame better is kept. Colour holds a far, noisy view (an office 2-5 m away,
  // whose depth distortion ICP follows) where depth misleads; near, clean depth holds the camera
  // where movers cover most of the view's texture (docs/experiments.md, "Bonn crowd").
  double photometric_weight = 10.0;
  double retry_photometric_weight = 1.0;
  // The camera's photometric residuals count by their tile's texture_tile_weights at this cap (a
  // region of the view with more gradient energy than `cap` typical regions counts as that many);
  // 0 = every region by its texture. A strongly textured object that starts to move slowly holds
  // most of the colour term and drags the camera along before it can be segmented. Off by
  // default: 8 keeps docs/validation/crossing.json's camera within 1.8 mm (3.0 without) and the
  // real recordings as they were, but five_objects' object 5 lands 14 mm off where its motion
  // reverses (docs/experiments.md, "Capping a region's share of the camera's colour term").
  double photometric_tile_cap = 0;
  // A replaced motion continues the constant-velocity guess at this fraction of its speed, so a
  // run of replaced frames slows down geometrically: the velocity came from frames that may
  // already be off, and a wrong velocity carried at full speed drifts without bound (Bonn crowd:
  // 2 cm per frame for 15 frames).
  double replaced_motion_scale = 0.5;
  // A refused motion stands after all when the model-tracked poses of this many refused frames in
  // a row each fit the previous frame's depth against the tracked pose before (0 = never): the
  // replaced path has drifted from the model, and the model's own poses agree with the frames.
  int agreeing_frames = 3;
  // A refused motion is moved this fraction of the way from its replacement (the slowed guess or
  // no motion) towards the camera pose that the frame's ORB features outside the excluded classes'
  // pixels give against the keyframes' (RANSAC PnP, as for relocalisation); the agreement rule is
  // not applied in such a frame. When movers fill the view the model and the previous frame can
  // both lead the camera astray (Bonn crowd: a pose 30 cm off that three refused frames agreed
  // on); the keyframes are evidence from neither. A fraction because each PnP pose is a few
  // centimetres off on its own: 1 takes it as it is, 0 switches this off.
  double keyframe_pose_gain = 0.5;
  // In a frame whose tracked motion stands, the camera's pose moves towards the keyframes'
  // features' pose (as above) by keyframe_pull_gain times the share of the image that the excluded
  // classes' pixels cover (0 = off), where at least keyframe_pull_min_inliers matches support
  // that pose. Where movers cover the view and the background left is far and bare, tracking
  // drifts by motions that each pass the check (Bonn crowd: 11 cm over ten frames) while the
  // features outside the movers still match the keyframes: the more of the view the movers take,
  // the less the tracked pose is worth against the keyframes' one. Without excluded pixels the
  // tracked pose stands as it is (on static views tracking is the better of the two). A pose from
  // few matches is too weak to overrule tracking: in the generated walking_people, where people
  // hide most of the room's texture, 19-74 matches gave poses centimetres off (the camera 4 cm
  // off, tracked alone 3 mm); Bonn's frames have hundreds.
  double keyframe_pull_gain = 1.0;
  int keyframe_pull_min_inliers = 100;
};

// The share of live pixels with depth (every step_px-th in x and y) that fit the reference depth
// under T_reference_live (live camera -> reference camera), as CameraCheckParams defines; 0 when
// no live pixel has depth. `depth_live_m`, `depth_reference_m`: width*height metres, 0 or NaN =
// no reading, both of the size `intrinsics` gives.
double depth_fit(const float* depth_live_m, const float* depth_reference_m, const Intrinsics& intrinsics,
                 const Eigen::Isometry3d& T_reference_live, const CameraCheckParams& params);

// How well the camera's tracked motion, the constant-velocity guess and no motion explain the
// previous frame's depth (depth_fit).
struct CameraFits {
  double tracked = 0, start = 0;  // fit of the tracked motion and of the better start
  bool from_guess = true;         // the better start is the constant-velocity guess (else no motion)
  Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();  // the constant-velocity guess
  bool refused(double min_fit_ratio) const { return tracked < min_fit_ratio * start; }
};

// What becomes of the camera's tracked motion in a frame.
enum class CameraVerdict {
  kStands,    // the tracked motion is the camera's
  kReplaced,  // `motion` is taken instead and nothing is fused into the background
  kLost,      // the tracking failed and nothing can stand in: the camera is lost
};
struct CameraDecision {
  CameraVerdict verdict = CameraVerdict::kStands;
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();  // the replacement (kReplaced)
};
// The rules of CameraCheckParams: a motion that tracked and is not refused stands, and so does a
// refused one whose poses agree (`refused_poses_agree`, the caller's count of agreeing frames
// reached). A refused motion is replaced by the better start: the constant-velocity guess slowed
// by replaced_motion_scale, or no motion. A failed tracking is replaced the same way when the
// start fits at least min_fit_ratio times `last_fit` (the last frame's taken motion's fit); else
// the camera is lost.
CameraDecision decide_camera_motion(const CameraFits& fits, bool tracking_failed, bool refused_poses_agree,
                                    double last_fit, const CameraCheckParams& params);

// The motion `gain` of the way from `from` to `to` (both T_reference_live): `from` followed by
// the difference between the two, scaled (scaled_motion). 0 gives `from`, 1 gives `to`.
Eigen::Isometry3d motion_towards(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to, double gain);

// The motion `scale` times as far: rotation angle (about the same axis) and translation scaled
// (CameraCheckParams::replaced_motion_scale). 0 gives no motion, 1 the motion itself.
Eigen::Isometry3d scaled_motion(const Eigen::Isometry3d& T, double scale);

}  // namespace cofusion::slam
