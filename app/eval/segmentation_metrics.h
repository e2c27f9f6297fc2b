#pragma once
// Segmentation quality as in the Co-Fusion paper (Sec. VI, "Motion segmentation"): the
// intersection-over-union of every ground-truth instance in every frame.
//
// Per frame, estimated labels (model ids; 0 is the background/camera model by our convention) are
// matched one-to-one to ground-truth instance ids (0 = static background) so that the total IoU
// is maximal (Hungarian algorithm); the matching is general, background included. A ground-truth
// id whose best assignment has no overlap counts as unmatched with IoU 0.
//
// Pixel conventions: ground-truth pixels equal to `gt_ignore_label` (0xFFFF) are left out entirely
// (neither image counts them). Estimated pixels equal to `est_unlabelled` (0xFFFF: no model claims
// the pixel) belong to no estimated label but still count in the ground-truth instance's area.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <vector>

namespace cofusion::eval {

struct SegmentationParams {
  std::uint16_t gt_ignore_label = 0xFFFF;  // ground-truth value meaning "do not evaluate this pixel"
  std::uint16_t est_unlabelled = 0xFFFF;   // estimated value meaning "no label"
};

struct LabelIou {
  int gt_label = 0;
  int est_label = -1;  // matched estimated label, -1 when unmatched
  double iou = 0;      // 0 when unmatched
  std::size_t gt_pixels = 0;
  std::size_t est_pixels = 0;      // of the matched estimated label (evaluated pixels only)
  std::size_t intersection = 0;
};

struct FrameSegmentation {
  std::vector<LabelIou> gt_labels;        // one per ground-truth id present in the frame, ascending
  std::vector<int> unmatched_est_labels;  // estimated labels present but matched to nothing, ascending
};

// Both images single-channel 8- or 16-bit of equal size (8-bit values are taken as they are).
// Throws cofusion::Error on a type or size mismatch.
FrameSegmentation evaluate_segmentation_frame(const cv::Mat& gt_labels, const cv::Mat& est_labels,
                                              const SegmentationParams& params = {});

struct LabelSummary {
  int gt_label = 0;
  std::size_t frames = 0;          // frames where the ground-truth id is present
  std::size_t frames_matched = 0;  // of those, frames where it was matched
  double mean_iou = 0;             // over `frames` (unmatched frames count as 0)
};

struct SegmentationSummary {
  std::vector<std::string> frame_names;   // one per evaluated frame (file name), same order as frames
  std::vector<FrameSegmentation> frames;
  std::vector<LabelSummary> labels;       // ascending ground-truth id
  double mean_label_iou = 0;              // mean of the per-label means
  std::size_t unmatched_est_labels = 0;   // summed over frames
  std::size_t frames_without_estimate = 0;  // ground-truth files with no estimated counterpart
};

SegmentationSummary summarize_segmentation(std::vector<std::string> frame_names, std::vector<FrameSegmentation> frames);

// Reads a label image (PNG etc.) unchanged and returns it as CV_16UC1. Throws cofusion::Error
// naming the file when it is missing, unreadable or not single-channel 8/16-bit.
cv::Mat read_label_image(const std::filesystem::path& path);

// Evaluates every image in `gt_dir` (extensions png, pgm, ppm, tif, tiff) against the image of the
// same stem in `est_dir`; ground-truth frames without an estimate are counted, not evaluated.
// Throws cofusion::Error when a folder is missing or no frame pairs up.
SegmentationSummary evaluate_segmentation_dirs(const std::filesystem::path& gt_dir, const std::filesystem::path& est_dir,
                                               const SegmentationParams& params = {});

}  // namespace cofusion::eval
