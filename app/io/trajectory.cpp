#include "io/trajectory.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "common/error.h"
#include "io/atomic_file.h"

namespace cofusion {

Trajectory read_tum_trajectory(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open trajectory file " + path.string());
  Trajectory out;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    for (char& c : line)
      if (c == ',' || c == '\t') c = ' ';
    const auto first = line.find_first_not_of(" \r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ss(line);
    double v[8];
    for (double& x : v)
      if (!(ss >> x)) throw Error(path.string() + ":" + std::to_string(line_no) + ": expected 8 numbers 't tx ty tz qx qy qz qw'");
    for (double x : v)
      if (!std::isfinite(x)) throw Error(path.string() + ":" + std::to_string(line_no) + ": non-finite value");
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    const double norm = q.norm();
    if (norm < 1e-6) throw Error(path.string() + ":" + std::to_string(line_no) + ": zero quaternion");
    q.coeffs() /= norm;
    TimedPose p;
    p.timestamp_s = v[0];
    p.T_world_x = Pose::Identity();
    p.T_world_x.linear() = q.toRotationMatrix();
    p.T_world_x.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    out.push_back(p);
  }
  return out;
}

std::string format_tum_line(const TimedPose& pose) {
  const Eigen::Quaterniond q(pose.T_world_x.rotation());
  const Eigen::Vector3d t = pose.T_world_x.translation();
  char buf[256];
  std::snprintf(buf, sizeof buf, "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f", pose.timestamp_s, t.x(), t.y(), t.z(),
                q.x(), q.y(), q.z(), q.w());
  return buf;
}

void write_tum_trajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  std::string text = "# timestamp tx ty tz qx qy qz qw\n";
  for (const auto& p : trajectory) text += format_tum_line(p) + "\n";
  write_text_atomically(path, text);
}

}  // namespace cofusion
