#include "io/source_adaptors.h"

#include <algorithm>

#include "common/error.h"
#include "io/intrinsics_option.h"

namespace cofusion {

LimitedSource::LimitedSource(std::unique_ptr<FrameSource> inner, int max_frames)
    : inner_(std::move(inner)), max_frames_(max_frames) {
  if (!inner_) throw Error("LimitedSource: no source given");
  if (max_frames_ < 0) throw Error("--max-frames must not be negative, got " + std::to_string(max_frames_));
}

std::optional<Frame> LimitedSource::next() {
  if (delivered_ >= max_frames_) return std::nullopt;
  try {
    auto frame = inner_->next();
    if (frame) ++delivered_;
    return frame;
  } catch (const BadFrame&) {
    ++delivered_;  // a bad frame counts: --max-frames N covers the source's first N frames
    throw;
  }
}

std::optional<int> LimitedSource::size() const {
  if (const auto n = inner_->size()) return std::min(*n, max_frames_);
  return std::nullopt;
}

std::string LimitedSource::describe() const {
  return inner_->describe() + " [first " + std::to_string(max_frames_) + " frames]";
}

DepthCorrectedSource::DepthCorrectedSource(std::unique_ptr<FrameSource> inner, double depth_correction)
    : inner_(std::move(inner)), depth_correction_(depth_correction) {
  if (!inner_) throw Error("DepthCorrectedSource: no source given");
  require_plausible_depth_correction(depth_correction_, inner_->describe());
}

std::optional<Frame> DepthCorrectedSource::next() {
  auto frame = inner_->next();
  // Into a new image: the inner source may share its pixels (cv::Mat copies are shallow, and
  // assigning a MatExpr to a Mat of the same size writes into its buffer).
  if (frame && !frame->depth_m.empty()) {
    cv::Mat corrected;
    frame->depth_m.convertTo(corrected, CV_32F, 1.0 / depth_correction_);  // 0 (no reading) stays 0
    frame->depth_m = corrected;
  }
  return frame;
}

std::string DepthCorrectedSource::describe() const {
  return inner_->describe() + " [" + depth_correction_label(depth_correction_, "--depth-correction") + "]";
}

MemorySource::MemorySource(std::vector<Frame> frames, Intrinsics intrinsics, std::string description)
    : frames_(std::move(frames)), intrinsics_(intrinsics), description_(std::move(description)) {
  for (std::size_t i = 0; i < frames_.size(); ++i) frames_[i].index = static_cast<int>(i);
}

std::optional<Frame> MemorySource::next() {
  if (next_ >= frames_.size()) return std::nullopt;
  return frames_[next_++];
}

std::string MemorySource::describe() const {
  return description_ + " (" + std::to_string(frames_.size()) + " frames in memory)";
}

}  // namespace cofusion
