#pragma once
// TUM RGB-D trajectory files: one pose per line, "timestamp tx ty tz qx qy qz qw", '#' comments.
// Poses are T_world_X (X-to-world), e.g. camera-to-world for camera trajectories.
#include <filesystem>
#include <vector>

#include "io/frame.h"

namespace cofusion {

struct TimedPose {
  double timestamp_s = 0;
  Pose T_world_x = Pose::Identity();
};
using Trajectory = std::vector<TimedPose>;

// Throws cofusion::Error naming the file and line on unreadable files or malformed lines.
Trajectory read_tum_trajectory(const std::filesystem::path& path);
// Written atomically (temporary name, then rename).
void write_tum_trajectory(const std::filesystem::path& path, const Trajectory& trajectory);
// Text form of one line, shared by the writer and by streaming writers.
std::string format_tum_line(const TimedPose& pose);

}  // namespace cofusion
