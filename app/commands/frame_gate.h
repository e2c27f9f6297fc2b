#pragma once
// What `cofusion run` does with a bad frame: one the source cannot read (a missing, corrupt or
// wrongly sized image), or one that reads but has the wrong size or no depth reading at all (a
// covered sensor, a dropped USB frame). Such a frame is skipped with a warning and listed; the
// pipeline never sees it, so tracking resumes at the next good frame across the gap in time.
#include <optional>
#include <string>
#include <vector>

#include "common/intrinsics.h"
#include "io/frame.h"

namespace cofusion::commands {

struct FrameGateParams {
  // --strict: the first bad frame ends the run with its error (before skipping existed, every bad
  // frame did).
  bool strict = false;
  // Bad frames in a row at the start, before any good one, after which the input counts as
  // unusable and the run fails: 30 frames = 1 s of a 30 Hz camera. A wrong path, intrinsics of the
  // wrong size or a sensor that never delivers depth fails here instead of skipping to the end.
  int max_leading_bad_frames = 30;
  // Skipped frames leave a gap in time. A gap longer than this (seconds of source time between the
  // processed frames either side) is relocalised across, as after a tracking loss: the camera may
  // have moved further than tracking from the last pose reaches (camera_loss: 31 cm in 1 s,
  // which ICP converges on wrongly). A shorter one is tracked as usual: fr2/desk with 5 frames
  // (0.17 s) skipped tracks within 0.1 mm of the intact run, while relocalisation on its young map
  // is refused for the rest of the run.
  double relocalise_after_gap_s = 0.5;
};

struct SkippedFrame {
  int frame = 0;       // the source's frame index
  std::string reason;  // names the file or what is wrong with the frame
};

// Why `frame` cannot be processed (its depth size differs from the intrinsics, or it has no valid
// depth reading), or std::nullopt when it can.
std::optional<std::string> bad_frame_reason(const Frame& frame, const Intrinsics& intrinsics);

// Hands out the source's good frames and skips the bad ones. Not thread-safe (one reader).
class FrameGate {
 public:
  FrameGate(FrameSource& source, const Intrinsics& intrinsics, FrameGateParams params);

  // The next good frame, or std::nullopt at the end of the source. Throws cofusion::Error naming the
  // frame and the reason when strict and a frame is bad, when the first max_leading_bad_frames
  // frames are all bad, or when the source ends without one good frame; the source's own fatal
  // errors pass through.
  std::optional<Frame> next();

  const std::vector<SkippedFrame>& skipped() const { return skipped_; }

 private:
  // Records the bad frame (a warning on stderr), or throws when it may not be skipped.
  void skip(int frame, const std::string& reason);

  FrameSource& source_;
  Intrinsics intrinsics_;
  FrameGateParams params_;
  std::vector<SkippedFrame> skipped_;
  int good_frames_ = 0;
};

}  // namespace cofusion::commands
