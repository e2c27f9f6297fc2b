#pragma once
// Trajectory metrics of the TUM RGB-D benchmark, reproducing its reference scripts:
//  - associate.py:     timestamp association (greedy on |dt|, each stamp used once);
//  - evaluate_ate.py:  absolute trajectory error after a rigid (no scale) Horn alignment of the
//                      matched positions;
//  - evaluate_rpe.py:  relative pose error with --fixed_delta (pairs one delta apart).
// Differences from the scripts: RPE uses every fixed-delta pair (the script randomly samples
// 10000 when there are more), and RPE supports the units seconds and frames only; lines with a
// zero quaternion or NaN are errors of read_tum_trajectory() where the RPE script skips them.
//
// Object trajectories (T_world_model from the system vs T_world_object ground truth) are compared by
// compute_object_trajectory_errors(); see ObjectTrajectoryErrors for what each measure assumes.
#include <cstddef>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "eval/error_stats.h"
#include "io/trajectory.h"

namespace cofusion::eval {

struct AssociationParams {
  double max_difference_s = 0.02;  // associate.py --max_difference: a pair needs |dt| < this
  double offset_s = 0.0;           // added to the second (estimated) trajectory's stamps
};

// A matched pair: indices into the first (ground-truth) and second (estimated) trajectory.
struct TimestampMatch {
  std::size_t first = 0;
  std::size_t second = 0;
};

// Sorted by time; of several poses with the same stamp the last in the file wins (the scripts
// read trajectories into a Python dict).
Trajectory sorted_unique(const Trajectory& trajectory);

// associate.py: every pair with |t_first - (t_second + offset)| < max_difference is a candidate;
// candidates are taken in order of increasing |dt| (ties: earlier first stamp, then earlier second
// stamp), skipping any whose stamps are already used. Result sorted by the first stamp.
std::vector<TimestampMatch> associate_timestamps(const Trajectory& first, const Trajectory& second,
                                                 const AssociationParams& params = {});

// Horn's closed-form rigid alignment (rotation + translation, no scale) in double precision, as
// evaluate_ate.py's align(): the T minimising sum |T * est[i] - gt[i]|^2. Needs >= 2 points of
// equal count; throws cofusion::Error otherwise.
Pose align_rigid(const std::vector<Eigen::Vector3d>& est_points, const std::vector<Eigen::Vector3d>& gt_points);

// The world alignment from full poses of the same rig in both worlds (a camera): the T with
// T * est(t) ~ gt(t) over the matched stamps, rotation the chordal mean of gt R est R^T, translation
// the mean of gt t - R est t. Unlike Horn's fit of positions it is fixed even for a camera that
// hardly moves. Throws cofusion::Error when no stamps match.
Pose align_by_poses(const Trajectory& gt, const Trajectory& est, const AssociationParams& params = {});

struct AteParams {
  AssociationParams association;
};

struct AteResult {
  ErrorStats translation_m;  // per matched pair |T_gt_est * p_est - p_gt|
  Pose T_gt_est = Pose::Identity();  // the alignment: maps estimated positions into the gt world
  std::vector<double> stamps_gt_s;   // per matched pair, in time order
  std::vector<double> stamps_est_s;
  std::vector<double> errors_m;
};

// Throws cofusion::Error when fewer than 2 stamps match (as the script does).
AteResult compute_ate(const Trajectory& gt, const Trajectory& est, const AteParams& params = {});

enum class RpeDeltaUnit { seconds, frames };

struct RpeParams {
  double delta = 1.0;                          // evaluate_rpe.py --delta
  RpeDeltaUnit unit = RpeDeltaUnit::seconds;   // --delta_unit s | f
  double offset_s = 0.0;                       // added to the estimated stamps
};

struct RpeResult {
  ErrorStats translation_m;
  ErrorStats rotation_deg;
  std::vector<double> stamps_est_s;  // first stamp of each evaluated pair
};

// Throws cofusion::Error when the trajectories hardly overlap or fewer than 2 pairs remain.
RpeResult compute_rpe(const Trajectory& gt, const Trajectory& est, const RpeParams& params = {});

// evaluate_rpe.py's find_closest_index (a binary search that remembers the closest value seen).
// `sorted` must be ascending and non-empty. Exposed for tests.
std::size_t find_closest_index(const std::vector<double>& sorted, double value);

// An object's trajectory from the system (model-<id>.txt, T_world_model: the model frame is the
// world frame at the time the object was first segmented, so T_world_model starts near identity)
// against its ground truth (groundtruth-<id>.txt, T_world_object in the object's own frame). The
// two frames are attached to the same rigid body but generally differ by a constant offset X
// (T_world_model ~ A * T_world_object * X, with A the world alignment), so three measures:
struct ObjectTrajectoryErrors {
  // 1. ATE of the frame origins: the model origin's positions against the object origin's after
  //    Horn's rigid alignment (exactly evaluate_ate.py). Unbiased only when the two origins are
  //    the same body point or the object does not rotate.
  AteResult origin_ate;
  // 2. Tracked-point ATE: the object's ground-truth origin, expressed in model coordinates
  //    (gt_origin_in_model, estimated jointly with the rigid alignment by Levenberg-Marquardt
  //    started from (1) and from a hand-eye solution; the better fit wins), is carried by
  //    T_world_model and compared with the ground-truth origin.
  //    Independent of where the system puts the model frame; never larger than (1). Needs clearly
  //    more matched poses than its 9 parameters to mean anything.
  ErrorStats tracked_point_m;
  Eigen::Vector3d gt_origin_in_model = Eigen::Vector3d::Zero();
  Pose T_gt_est_tracked_point = Pose::Identity();
  // 3. Relative motion from the first matched time t0: T_world_model(t0)^-1 T_world_model(t) vs
  //    T_world_object(t0)^-1 T_world_object(t), error = inv(est) * gt as in RPE, for every later
  //    matched t. Needs no world alignment; equal motions give zero only when the model and object
  //    frames coincide up to a translation for the rotation part, and coincide fully for the
  //    translation part ((I - R) * offset otherwise).
  ErrorStats relative_translation_m;
  ErrorStats relative_rotation_deg;
  // 4. Drift since the first matched time t0, in the world, with a world alignment W and a point
  //    q: translation |e(t) - e(t0)| of the tracked point's error e(t) = W T_world_model(t) q
  //    - g(t). With W given, q is the object's own origin at t0 (q = (W T_world_model(t0))^-1
  //    g(t0), e(t0) = 0): how far the model's motion since t0 carries the object's centre from
  //    where its true motion does, with no per-object fit (a can's unobservable turn about its
  //    axis leaves its centre in place; a fitted q off the axis turned it into centimetres of
  //    drift). Without W, (2)'s q. Rotation, the angle between the world-frame rotations since t0, W R_model(t)
  //    R_model(t0)^T W^T against R_object(t) R_object(t0)^T (independent of the body offset). (2)
  //    aligns the whole trajectory, so a model that slipped once and then rested long is mostly
  //    absorbed there; here the slip stays in every later frame. W is the given world alignment
  //    (ObjectTrajectoryParams::T_gt_est_world, e.g. the cameras') or else (2)'s A, whose
  //    rotation a straight or planar path leaves partly free: a sliding box's model that turned
  //    with it then shows tens of degrees of rotation drift that is not there.
  ErrorStats drift_translation_m;
  ErrorStats drift_rotation_deg;
  bool drift_in_given_world = false;  // W was given (else (2)'s A)
  // 5. Drift relative to the camera, where both camera trajectories are given
  //    (ObjectTrajectoryParams::cameras): (4) with the object's pose in the camera at each stamp,
  //    T_camera_model = T_world_camera^-1 T_world_model against T_world_camera^-1 T_world_object,
  //    in place of the world poses (no alignment needed). What is left of (4) once the camera's
  //    own errors are taken out: the object's tracking. Where (4) is large and this small, the
  //    camera carried the object off (a moving object the camera followed before it was found
  //    shifts every model found meanwhile). Stamps without a camera pose on either side are left
  //    out; count 0 when no cameras are given.
  ErrorStats camera_relative_drift_m;
  // (4) per matched stamp, the first (zero drift) included: what `eval objects --plot` draws.
  struct DriftSample {
    double timestamp_s = 0;  // the ground truth's
    double translation_m = 0;
    double rotation_deg = 0;
    double camera_relative_m = std::numeric_limits<double>::quiet_NaN();  // (5); NaN where unknown
  };
  std::vector<DriftSample> drift_series;
};

// The ground-truth and estimated camera trajectories (T_world_camera), for (5) above.
struct CameraTrajectories {
  Trajectory gt;
  Trajectory est;
};

struct ObjectTrajectoryParams {
  AssociationParams association;
  // Maps the estimate's world into the ground truth's, e.g. the camera trajectories' ATE alignment
  // (ObjectTrajectoryErrors' drift is measured in it). Empty: the tracked-point fit's alignment.
  std::optional<Pose> T_gt_est_world;
  // Both cameras' trajectories, for the drift relative to the camera; null: not computed.
  std::shared_ptr<const CameraTrajectories> cameras;
  int max_iterations = 100;            // tracked-point Levenberg-Marquardt iterations
  double convergence_rmse_m = 1e-12;   // stop when an iteration improves the RMSE by less than this
};

// Throws cofusion::Error when fewer than 2 stamps match.
ObjectTrajectoryErrors compute_object_trajectory_errors(const Trajectory& gt_object, const Trajectory& est_model,
                                                        const ObjectTrajectoryParams& params = {});

}  // namespace cofusion::eval
