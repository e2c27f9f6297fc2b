#pragma once
// Instance masks for `cofusion run` (slam::SemanticFrame): from the input's own masks
// (Frame::mask + Frame::mask_classes), or from the built-in detector (compute/semantic: CenterNet
// boxes, the person segmenter, instance_masks()) run asynchronously on the CPU job system.
#include <atomic>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <tbb/task_group.h>

#include "io/frame.h"
#include "semantic/detector.h"
#include "semantic/instance_masks.h"
#include "slam/semantic_masks.h"

namespace cofusion::commands {

// The detector's models: $COFUSION_MODELS, else build/models beside build/app/cofusion (the folder
// .ci/fetch-models.sh fills by default).
std::filesystem::path default_models_dir();

// A frame's own masks as the pipeline takes them; nullopt when it has none.
std::optional<slam::SemanticFrame> semantic_frame_from_masks(const Frame& frame);

// The detector on a TBB task, one frame at a time. The pipeline never waits for it: submit()
// starts a detection on a frame when none is running (else the frame is skipped), and
// for_frame() hands out the latest finished result for the frames after the one it was made
// from, up to max_age_frames frames after it, with SemanticFrame::age_frames set (CoFusion carries
// the masks to each frame by the camera's motion) and SemanticFrame::repeated from its second
// frame on. Ages count for_frame() calls: one per processed frame. A result made from frame k is
// first used for frame k + 1 when it finished before that frame is processed (it cannot be used
// for frame k itself without waiting).
// With `wait_for_result` (recordings), for_frame() first waits for a running detection, so each
// frame gets the previous frame's result whatever the timing: runs are reproducible. A live camera
// does not wait (frames keep coming). With `every_frames` N > 1 detections start only on frames
// whose index is a multiple of N (the detector's share of the CPU bounded), and each result is
// carried to the N frames until the next one.
class AsyncDetector {
 public:
  // models: folder with centernet.pb and selfie.pb. Throws cofusion::Error naming a missing file.
  AsyncDetector(const std::filesystem::path& models, const Intrinsics& intrinsics, bool wait_for_result,
                int every_frames = 1, int max_age_frames = 1);
  ~AsyncDetector();  // waits for a running detection
  AsyncDetector(const AsyncDetector&) = delete;
  AsyncDetector& operator=(const AsyncDetector&) = delete;

  // Starts a detection on this frame (its pixels are copied) unless one is running or the frame
  // is not one of every_frames. Call it after for_frame() of the same frame. Returns whether it
  // started.
  bool submit(int frame_index, const cv::Mat& rgb, const cv::Mat& depth_m);
  // The masks for the next processed frame (see the class comment), or null. Valid until the next
  // call.
  const slam::SemanticFrame* for_frame();

  int detections_started() const { return started_; }
  int results_used() const { return used_; }
  double mean_detection_ms() const { return finished_ > 0 ? total_ms_ / finished_ : 0.0; }

 private:
  semantic::Detector detector_;
  semantic::PersonSegmenter segmenter_;
  Intrinsics intrinsics_;
  bool wait_for_result_;
  int every_frames_;
  int max_age_frames_;
  tbb::task_group jobs_;
  std::atomic<bool> running_{false};
  int calls_ = -1;  // for_frame() calls so far, minus one: the current frame's position
  // Written by the task before running_ is cleared, read by the caller after it saw it cleared.
  int result_call_ = -1;  // calls_ when the result's frame was submitted
  slam::SemanticFrame result_;
  double total_ms_ = 0;
  int finished_ = 0, started_ = 0, used_ = 0;
  // The result handed out (a copy: the task may overwrite result_ meanwhile).
  slam::SemanticFrame current_;
  int current_call_ = -1;
  bool current_handed_out_ = false;  // current_ was returned for an earlier frame
};

// Where the instance masks come from when --semantic-source does not say, decided at the first
// frame: the input's masks, else the detector when its models are there, else none (each choice
// printed, with why there are none).
std::string choose_semantic_source(const Frame& first, bool motion_segmentation);

// The instance masks each frame gets: the input's (`masks`), the built-in detector's (`detector`)
// or none; with an empty source, chosen at the first frame (choose_semantic_source). Used by
// `cofusion run` and `cofusion bench`.
class FrameMasks {
 public:
  FrameMasks(std::string source, bool motion_segmentation, const Intrinsics& intrinsics, bool wait_for_detections,
             int detector_every);

  // This frame's masks (null: none). The detector gives its latest detection made from an earlier
  // frame (AsyncDetector::for_frame), then starts one of this frame (when none is running); with
  // wait_for_detections (recordings) the next frame waits for it, a live camera never does. Throws cofusion::Error for a frame
  // without masks when the source is `masks`.
  const slam::SemanticFrame* for_frame(const Frame& frame, const cv::Mat& rgb, const cv::Mat& depth_m);

  const std::string& source() const { return source_; }
  const AsyncDetector* detector() const { return detector_.get(); }

 private:
  std::string source_;
  const bool motion_segmentation_;
  const Intrinsics intrinsics_;
  const bool wait_for_detections_;
  const int detector_every_;
  std::unique_ptr<AsyncDetector> detector_;
  std::optional<slam::SemanticFrame> masks_;
};

}  // namespace cofusion::commands
