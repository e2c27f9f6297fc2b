#include "commands/frame_gate.h"

#include <cstdio>

#include "common/error.h"

namespace cofusion::commands {

std::optional<std::string> bad_frame_reason(const Frame& frame, const Intrinsics& intrinsics) {
  if (frame.depth_m.cols != intrinsics.width || frame.depth_m.rows != intrinsics.height)
    return "depth is " + std::to_string(frame.depth_m.cols) + "x" + std::to_string(frame.depth_m.rows) +
           " but the intrinsics say " + std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height);
  if (frame.rgb.cols != intrinsics.width || frame.rgb.rows != intrinsics.height)
    return "colour is " + std::to_string(frame.rgb.cols) + "x" + std::to_string(frame.rgb.rows) +
           " but the intrinsics say " + std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height);
  if (cv::countNonZero(frame.depth_m > 0.0f) == 0)  // NaN compares false
    return "no valid depth reading (all zero or NaN) at t=" + std::to_string(frame.timestamp_s);
  return std::nullopt;
}

FrameGate::FrameGate(FrameSource& source, const Intrinsics& intrinsics, FrameGateParams params)
    : source_(source), intrinsics_(intrinsics), params_(params) {}

std::optional<Frame> FrameGate::next() {
  while (true) {
    std::optional<Frame> frame;
    try {
      frame = source_.next();
    } catch (const BadFrame& e) {
      skip(e.frame_index(), e.reason());
      continue;
    }
    if (!frame) {
      if (good_frames_ == 0 && !skipped_.empty())
        throw Error("no usable frame: all " + std::to_string(skipped_.size()) + " frames are bad (frame " +
                    std::to_string(skipped_.front().frame) + ": " + skipped_.front().reason + ")");
      return std::nullopt;
    }
    if (const auto reason = bad_frame_reason(*frame, intrinsics_)) {
      skip(frame->index, *reason);
      continue;
    }
    ++good_frames_;
    return frame;
  }
}

void FrameGate::skip(int frame, const std::string& reason) {
  if (params_.strict) throw Error("frame " + std::to_string(frame) + ": " + reason + " (--strict)");
  skipped_.push_back({frame, reason});
  if (good_frames_ == 0 && static_cast<int>(skipped_.size()) >= params_.max_leading_bad_frames)
    throw Error("the first " + std::to_string(skipped_.size()) + " frames are all bad; giving up (frame " +
                std::to_string(skipped_.front().frame) + ": " + skipped_.front().reason + ")");
  std::fprintf(stderr, "warning: frame %d skipped: %s\n", frame, reason.c_str());
}

}  // namespace cofusion::commands
