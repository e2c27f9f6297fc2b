#pragma once
// The pose of a trajectory at an arbitrary time, e.g. ground truth (sampled at 100 Hz in TUM)
// at an image's timestamp.
#include <optional>

#include "io/trajectory.h"

namespace cofusion {

// Linear interpolation of translation and slerp of rotation; alpha 0 gives a, 1 gives b.
Pose interpolate_pose(const Pose& a, const Pose& b, double alpha);

// `trajectory` sorted by time (ascending). When t lies between two samples that are both within
// max_dt_s of it, the interpolated pose; else the nearest sample when it is within max_dt_s; else
// std::nullopt (t outside the trajectory or in a gap).
std::optional<Pose> pose_at(const Trajectory& trajectory, double t, double max_dt_s);

}  // namespace cofusion
