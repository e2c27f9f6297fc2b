#include "eval/drift_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <span>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "io/atomic_file.h"

namespace cofusion::eval {
namespace {

const cv::Scalar kTranslationColour(200, 80, 0);  // BGR: blue
const cv::Scalar kRotationColour(0, 0, 200);      // red
const cv::Scalar kCameraRelativeColour(60, 160, 0);  // green: translation relative to the camera
const cv::Scalar kAxisColour(60, 60, 60);

// A "nice" upper bound of an axis: 1, 2 or 5 times a power of ten, at least `max_value`.
double axis_top(double max_value) {
  if (!(max_value > 0)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(max_value)));
  for (double f : {1.0, 2.0, 5.0, 10.0})
    if (f * p >= max_value) return f * p;
  return 10.0 * p;
}

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

void put(cv::Mat& img, const std::string& text, cv::Point at, const cv::Scalar& colour) {
  cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv::LINE_AA);
}

}  // namespace

cv::Mat plot_drift(const ObjectPairResult& pair, const DriftPlotParams& p) {
  cv::Mat img(p.height_px, p.width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto& series = pair.errors.drift_series;
  const cv::Rect area(p.margin_px, p.margin_px / 2, p.width_px - 2 * p.margin_px, p.height_px - 3 * p.margin_px / 2);
  cv::rectangle(img, area, kAxisColour, 1);
  const double t0 = series.empty() ? 0.0 : series.front().timestamp_s;
  double t_max = 0, mm_max = 0, deg_max = 0;
  for (const auto& s : series) {
    t_max = std::max(t_max, s.timestamp_s - t0);
    mm_max = std::max(mm_max, 1000.0 * s.translation_m);
    if (std::isfinite(s.camera_relative_m)) mm_max = std::max(mm_max, 1000.0 * s.camera_relative_m);
    deg_max = std::max(deg_max, s.rotation_deg);
  }
  const double t_top = t_max > 0 ? t_max : 1.0, mm_top = axis_top(mm_max), deg_top = axis_top(deg_max);
  const auto at = [&](double t, double value, double top) {
    return cv::Point(area.x + int(std::lround((t - t0) / t_top * area.width)),
                     area.y + area.height - int(std::lround(std::min(value / top, 1.0) * area.height)));
  };
  for (size_t i = 1; i < series.size(); ++i) {
    const double before_m = series[i - 1].camera_relative_m, now_m = series[i].camera_relative_m;
    if (std::isfinite(before_m) && std::isfinite(now_m))
      cv::line(img, at(series[i - 1].timestamp_s, 1000.0 * before_m, mm_top), at(series[i].timestamp_s, 1000.0 * now_m, mm_top),
               kCameraRelativeColour, 1, cv::LINE_AA);
    cv::line(img, at(series[i - 1].timestamp_s, 1000.0 * series[i - 1].translation_m, mm_top),
             at(series[i].timestamp_s, 1000.0 * series[i].translation_m, mm_top), kTranslationColour, 2, cv::LINE_AA);
    cv::line(img, at(series[i - 1].timestamp_s, series[i - 1].rotation_deg, deg_top),
             at(series[i].timestamp_s, series[i].rotation_deg, deg_top), kRotationColour, 1, cv::LINE_AA);
  }
  put(img, number(mm_top) + " mm", {area.x, area.y - 6}, kTranslationColour);
  put(img, "0", {area.x - 14, area.y + area.height}, kAxisColour);
  const std::string deg_label = number(deg_top) + " deg";
  int baseline = 0;
  const cv::Size deg_size = cv::getTextSize(deg_label, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &baseline);
  put(img, deg_label, {area.x + area.width - deg_size.width, area.y - 6}, kRotationColour);
  put(img, number(t_max) + " s", {area.x + area.width - 30, area.y + area.height + 16}, kAxisColour);
  char title[160];
  std::snprintf(title, sizeof title, "model %d vs object %d: drift since first seen (translation max %.1f mm, rotation max %.1f deg)",
                pair.est_id, pair.gt_id, 1000.0 * pair.errors.drift_translation_m.max, deg_max);
  if (const ErrorStats& relative = pair.errors.camera_relative_drift_m; relative.count > 0) {
    char legend[96];
    std::snprintf(legend, sizeof legend, "translation relative to the camera: max %.1f mm", 1000.0 * relative.max);
    const cv::Size size = cv::getTextSize(legend, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &baseline);
    put(img, legend, {area.x + (area.width - size.width) / 2, area.y - 6}, kCameraRelativeColour);
  }
  put(img, title, {area.x, p.height_px - 10}, kAxisColour);
  return img;
}

void write_drift_plots(const ObjectsEvaluation& evaluation, const std::filesystem::path& dir, const DriftPlotParams& params) {
  ensure_writable_directory(dir);
  for (const ObjectPairResult& pair : evaluation.pairs) {
    const std::filesystem::path path = dir / ("drift-model-" + std::to_string(pair.est_id) + ".png");
    std::vector<uchar> png;
    if (!cv::imencode(".png", plot_drift(pair, params), png)) throw Error("cannot encode " + path.string());
    write_bytes_atomically(path, std::as_bytes(std::span<const uchar>(png)));
  }
}

}  // namespace cofusion::eval
