#include "io/source_adaptors.h"

#include <algorithm>

#include "common/error.h"

namespace cofusion {

LimitedSource::LimitedSource(std::unique_ptr<FrameSource> inner, int max_frames)
    : inner_(std::move(inner)), max_frames_(max_frames) {
  if (!inner_) throw Error("LimitedSource: no source given");
  if (max_frames_ < 0) throw Error("--max-frames must not be negative, got " + std::to_string(max_frames_));
}

std::optional<Frame> LimitedSource::next() {
  if (delivered_ >= max_frames_) return std::nullopt;
  auto frame = inner_->next();
  if (frame) ++delivered_;
  return frame;
}

std::optional<int> LimitedSource::size() const {
  if (const auto n = inner_->size()) return std::min(*n, max_frames_);
  return std::nullopt;
}

std::string LimitedSource::describe() const {
  return inner_->describe() + " [first " + std::to_string(max_frames_) + " frames]";
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
