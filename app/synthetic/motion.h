#pragma once
// Poses over time: keyframe interpolation (linear translation, slerp rotation) and the hand-held
// camera jitter.
#include "io/frame.h"
#include "synthetic/scene.h"

namespace cofusion::synthetic {

// Pose of `path` at time t_s: held constant before the first and after the last keyframe; between
// keyframes translation is interpolated linearly and rotation by slerp, on the segment parameter
// (smoothstep-eased when path.interpolation is kSmooth).
Pose interpolate(const KeyframedPath& path, double t_s);

// Jitter transform T_smooth_jittered at time t_s (apply on the right of the smooth camera pose, so
// it acts in the camera frame). Identity when both amplitudes are 0. Deterministic from `seed`.
Pose camera_jitter(const JitterDesc& jitter, unsigned seed, double t_s);

// Rotation whose camera z axis looks from `eye` to `target`, with camera y (down) opposite to
// `up_world` as far as possible. Throws cofusion::Error when eye == target or the view is along up.
Eigen::Matrix3d look_at_rotation(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                                 const Eigen::Vector3d& up_world);

}  // namespace cofusion::synthetic
