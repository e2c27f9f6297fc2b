#pragma once
// One RGB-D frame and the interface every input source implements.
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "common/intrinsics.h"
#include "io/instance_classes.h"

namespace cofusion {

// Rigid transform in double precision. Named by frames: T_world_camera maps camera-frame points
// to world-frame points (camera-to-world, as TUM ground truth is).
using Pose = Eigen::Isometry3d;

struct Frame {
  int index = 0;            // 0-based position in the source
  double timestamp_s = 0;   // seconds (source clock)
  cv::Mat rgb;              // CV_8UC3, R,G,B byte order, size = intrinsics
  cv::Mat depth_m;          // CV_32FC1 metres, 0 = no reading (never NaN/inf once read)
  cv::Mat mask;             // CV_16UC1 instance ids (0 = background / none); empty if unavailable
  // Class of each mask id, shared by every frame of a source (read once); null when the source
  // has no class table. When set, every non-zero id of `mask` has a class in it.
  std::shared_ptr<const InstanceClasses> mask_classes;
  Intrinsics intrinsics;
  std::optional<Pose> T_world_camera_gt;  // ground truth when the source has it
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Next frame, or std::nullopt at the end. Throws cofusion::Error naming the file or frame on bad
  // input (missing/corrupt files, size mismatches).
  virtual std::optional<Frame> next() = 0;
  virtual Intrinsics intrinsics() const = 0;
  // Number of frames when known in advance.
  virtual std::optional<int> size() const { return std::nullopt; }
  // One line for the terminal, e.g. "tum:/data/fr2_desk (50 frames, fr2 intrinsics)".
  virtual std::string describe() const = 0;
};

}  // namespace cofusion
