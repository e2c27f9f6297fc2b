#pragma once
// Small FrameSource building blocks: a frame-count limit around any source, a depth correction,
// and frames held in memory (tests, and producers that build frames themselves).
#include <memory>
#include <string>
#include <vector>

#include "io/frame.h"

namespace cofusion {

// Yields at most `max_frames` frames of `inner` (max_frames >= 0), bad frames included; never reads
// past the limit.
class LimitedSource : public FrameSource {
 public:
  LimitedSource(std::unique_ptr<FrameSource> inner, int max_frames);

  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override { return inner_->intrinsics(); }
  std::optional<int> size() const override;
  long dropped_frames() const override { return inner_->dropped_frames(); }
  std::string describe() const override;

 private:
  std::unique_ptr<FrameSource> inner_;
  int max_frames_;
  int delivered_ = 0;
};

// Divides every depth reading of `inner` by `depth_correction` (0.5-2): a sensor whose depth reads
// long or short by a known factor (--depth-correction for recordings other than TUM folders,
// which apply it themselves).
class DepthCorrectedSource : public FrameSource {
 public:
  DepthCorrectedSource(std::unique_ptr<FrameSource> inner, double depth_correction);

  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override { return inner_->intrinsics(); }
  std::optional<int> size() const override { return inner_->size(); }
  long dropped_frames() const override { return inner_->dropped_frames(); }
  std::string describe() const override;

 private:
  std::unique_ptr<FrameSource> inner_;
  double depth_correction_;
};

// Hands out the given frames in order (each frame's index is set to its position).
class MemorySource : public FrameSource {
 public:
  MemorySource(std::vector<Frame> frames, Intrinsics intrinsics, std::string description = "memory");

  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override { return intrinsics_; }
  std::optional<int> size() const override { return static_cast<int>(frames_.size()); }
  std::string describe() const override;

 private:
  std::vector<Frame> frames_;
  Intrinsics intrinsics_;
  std::string description_;
  std::size_t next_ = 0;
};

}  // namespace cofusion
