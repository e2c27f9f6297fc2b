#pragma once
// One RGB-D frame and the interface every input source implements.
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "common/error.h"
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
  // The colour camera's rolling-shutter readout, seconds (slam::RollingShutterParams), where the
  // source knows its camera; 0 = a global shutter or unknown.
  double colour_readout_s = 0.0;
};

// One frame a source could not read: an image that is missing, cannot be decoded or has the wrong
// size, a damaged block of a log. The source has moved past it, so next() may be called again and
// continues with the following frame; a caller that cannot use a gap treats it as any Error.
class BadFrame : public Error {
 public:
  BadFrame(int frame_index, const std::string& reason)
      : Error("frame " + std::to_string(frame_index) + ": " + reason), frame_index_(frame_index), reason_(reason) {}
  int frame_index() const { return frame_index_; }
  const std::string& reason() const { return reason_; }  // names the file or block

 private:
  int frame_index_;
  std::string reason_;
};

// Runs read() for frame `frame_index`, turning the cofusion::Error or OpenCV exception it throws
// into BadFrame: for sources whose frames are independent files or blocks.
template <class Read>
Frame read_or_bad_frame(int frame_index, Read&& read) {
  try {
    return read();
  } catch (const BadFrame&) {
    throw;
  } catch (const Error& e) {
    throw BadFrame(frame_index, e.what());
  } catch (const cv::Exception& e) {
    throw BadFrame(frame_index, e.what());
  }
}

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Next frame, or std::nullopt at the end. Throws BadFrame for one unreadable frame (the source
  // has passed it), cofusion::Error naming the file or device for a fault that ends the source.
  virtual std::optional<Frame> next() = 0;
  virtual Intrinsics intrinsics() const = 0;
  // Number of frames when known in advance.
  virtual std::optional<int> size() const { return std::nullopt; }
  // Live sources: frames the device delivered that were dropped because the reader was busy (the
  // newest frame wins). Recordings drop none.
  virtual long dropped_frames() const { return 0; }
  // One line for the terminal, e.g. "tum:/data/fr2_desk (50 frames, fr2 intrinsics)".
  virtual std::string describe() const = 0;
};

}  // namespace cofusion
