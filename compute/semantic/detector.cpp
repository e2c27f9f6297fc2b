#include "semantic/detector.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <tuple>

#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "semantic/coco_classes.h"

namespace cofusion::semantic {

std::string coco_class_name(int class_id) {
  if (class_id >= 0 && class_id < static_cast<int>(kCocoClassNames.size()))
    return std::string(kCocoClassNames[static_cast<size_t>(class_id)]);
  return "class_" + std::to_string(class_id);
}

std::vector<Detection> decode_centernet(std::span<const float> heatmap, std::span<const float> wh, int classes,
                                        int rows, int cols, int input_size_px, cv::Size image_size,
                                        const DetectorParams& params) {
  if (classes <= 0 || rows <= 0 || cols <= 0 || input_size_px <= 0)
    throw Error("decode_centernet: empty output (" + std::to_string(classes) + " classes, " + std::to_string(rows) +
                "x" + std::to_string(cols) + ")");
  const size_t plane = static_cast<size_t>(rows) * static_cast<size_t>(cols);
  if (heatmap.size() != plane * static_cast<size_t>(classes) || wh.size() != plane * 4)
    throw Error("decode_centernet: heatmap or wh size does not match " + std::to_string(classes) + "x" +
                std::to_string(rows) + "x" + std::to_string(cols));

  struct Peak {
    float score;
    int cls, row, col;
  };
  std::vector<Peak> peaks;
  for (int c = 0; c < classes; ++c) {
    const float* h = heatmap.data() + plane * static_cast<size_t>(c);
    for (int y = 0; y < rows; ++y)
      for (int x = 0; x < cols; ++x) {
        const float v = h[static_cast<size_t>(y) * cols + x];
        if (!(v > params.score_threshold)) continue;
        bool peak = true;
        for (int dy = -1; dy <= 1 && peak; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            if (dx == 0 && dy == 0) continue;
            const int ny = y + dy, nx = x + dx;
            if (ny < 0 || ny >= rows || nx < 0 || nx >= cols) continue;
            const float n = h[static_cast<size_t>(ny) * cols + nx];
            const bool earlier = dy < 0 || (dy == 0 && dx < 0);
            if (n > v || (earlier && n == v)) {
              peak = false;
              break;
            }
          }
        if (peak) peaks.push_back({v, c, y, x});
      }
  }
  auto better = [](const Peak& a, const Peak& b) {
    return std::tie(b.score, a.cls, a.row, a.col) < std::tie(a.score, b.cls, b.row, b.col);
  };
  std::sort(peaks.begin(), peaks.end(), better);
  if (params.one_class_per_cell) {
    std::vector<uint8_t> taken(plane, 0);
    std::erase_if(peaks, [&](const Peak& p) {
      uint8_t& t = taken[static_cast<size_t>(p.row) * cols + p.col];
      const bool drop = t != 0;
      t = 1;
      return drop;
    });
  }
  if (params.max_detections >= 0 && peaks.size() > static_cast<size_t>(params.max_detections))
    peaks.resize(static_cast<size_t>(params.max_detections));

  const float stride = static_cast<float>(input_size_px) / static_cast<float>(cols);
  const float stride_y = static_cast<float>(input_size_px) / static_cast<float>(rows);
  const float sx = static_cast<float>(image_size.width) / static_cast<float>(input_size_px);
  const float sy = static_cast<float>(image_size.height) / static_cast<float>(input_size_px);
  const float w = static_cast<float>(image_size.width), h = static_cast<float>(image_size.height);
  std::vector<Detection> out;
  out.reserve(peaks.size());
  for (const Peak& p : peaks) {
    const size_t i = static_cast<size_t>(p.row) * cols + p.col;
    // The graph's own decoder measures from the cell's top-left corner times the stride.
    const float cx = static_cast<float>(p.col) * stride, cy = static_cast<float>(p.row) * stride_y;
    // Clamped coordinate by coordinate (not cv::Rect's intersection, which moves an empty box to 0, 0).
    const float x0 = std::clamp((cx - wh[i]) * sx, 0.f, w), y0 = std::clamp((cy - wh[plane + i]) * sy, 0.f, h);
    const float x1 = std::clamp((cx + wh[2 * plane + i]) * sx, x0, w);
    const float y1 = std::clamp((cy + wh[3 * plane + i]) * sy, y0, h);
    Detection d;
    d.class_id = p.cls;
    d.class_name = coco_class_name(p.cls);
    d.score = p.score;
    d.box_px = cv::Rect2f(x0, y0, x1 - x0, y1 - y0);
    out.push_back(std::move(d));
  }
  return out;
}

namespace {

cv::dnn::Net load_graph(const std::filesystem::path& pb, const char* what) {
  if (!std::filesystem::is_regular_file(pb))
    throw Error(std::string(what) + ": model file " + pb.string() + " not found: run .ci/fetch-models.sh");
  try {
    cv::dnn::Net net = cv::dnn::readNetFromTensorflow(pb.string());
    if (net.empty()) throw Error(std::string(what) + ": " + pb.string() + " holds no network");
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
    return net;
  } catch (const cv::Exception& e) {
    throw Error(std::string(what) + ": cannot read " + pb.string() + " (" + e.err +
                "); convert it again with .ci/fetch-models.sh");
  }
}

void check_rgb(const cv::Mat& rgb, const char* what) {
  if (rgb.empty() || rgb.type() != CV_8UC3)
    throw Error(std::string(what) + ": expected a CV_8UC3 RGB image, got " +
                (rgb.empty() ? std::string("an empty one") : "type " + std::to_string(rgb.type())));
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

Detector::Detector(const std::filesystem::path& centernet_pb, DetectorParams params)
    : params_(params), net_(load_graph(centernet_pb, "semantic detector")) {}

std::vector<Detection> Detector::detect(const cv::Mat& rgb) {
  check_rgb(rgb, "semantic detector");
  // Already RGB: no channel swap; raw 0..255; stretched (not cropped) to 512x512.
  const cv::Mat blob =
      cv::dnn::blobFromImage(rgb, 1.0, cv::Size(kInputSizePx, kInputSizePx), cv::Scalar(), false, false, CV_32F);
  net_.setInput(blob);
  std::vector<cv::Mat> outs;
  const auto t0 = std::chrono::steady_clock::now();
  net_.forward(outs, std::vector<cv::String>{"tower_0/keypoints", "tower_0/wh"});
  last_forward_ms_ = ms_since(t0);
  const cv::Mat& hm = outs[0];
  const cv::Mat& wh = outs[1];
  if (hm.dims != 4 || wh.dims != 4 || wh.size[1] != 4 || hm.size[2] != wh.size[2] || hm.size[3] != wh.size[3] ||
      !hm.isContinuous() || !wh.isContinuous())
    throw Error("semantic detector: unexpected output shapes (convert the model again with .ci/fetch-models.sh)");
  const int classes = hm.size[1], rows = hm.size[2], cols = hm.size[3];
  return decode_centernet(std::span<const float>(hm.ptr<float>(), hm.total()),
                          std::span<const float>(wh.ptr<float>(), wh.total()), classes, rows, cols, kInputSizePx,
                          rgb.size(), params_);
}

PersonSegmenter::PersonSegmenter(const std::filesystem::path& selfie_pb)
    : net_(load_graph(selfie_pb, "person segmenter")) {}

cv::Mat PersonSegmenter::segment(const cv::Mat& rgb) {
  check_rgb(rgb, "person segmenter");
  const cv::Mat blob = cv::dnn::blobFromImage(rgb, 1.0 / 255.0, cv::Size(kInputSizePx, kInputSizePx), cv::Scalar(),
                                              false, false, CV_32F);
  net_.setInput(blob);
  const auto t0 = std::chrono::steady_clock::now();
  const cv::Mat out = net_.forward();
  last_forward_ms_ = ms_since(t0);
  if (out.dims != 4 || out.size[1] != 1)
    throw Error("person segmenter: unexpected output shape (convert the model again with .ci/fetch-models.sh)");
  const cv::Mat prob(out.size[2], out.size[3], CV_32FC1, const_cast<float*>(out.ptr<float>()));
  cv::Mat resized;
  cv::resize(prob, resized, rgb.size(), 0, 0, cv::INTER_LINEAR);
  return resized;
}

std::filesystem::path models_dir(const std::filesystem::path& fallback) {
  const char* env = std::getenv("COFUSION_MODELS");
  return env != nullptr && *env != '\0' ? std::filesystem::path(env) : fallback;
}

}  // namespace cofusion::semantic
