#pragma once
// `cofusion eval objects --plot DIR`: per object, its drift since it was first seen (translation,
// mm, and rotation, degrees) against time, as a PNG line chart. Makes a model that lags while its
// object moves, or slips once, visible at a glance (issue "Accuracy").
#include <filesystem>

#include <opencv2/core.hpp>

#include "eval/object_evaluation.h"

namespace cofusion::eval {

struct DriftPlotParams {
  int width_px = 800;
  int height_px = 400;
  int margin_px = 50;  // around the plot area, for the axes' labels
};

// The chart of one pair: translation drift (blue, left axis, mm) and rotation drift (red, right
// axis, degrees) against seconds since the first matched stamp. White background, BGR.
cv::Mat plot_drift(const ObjectPairResult& pair, const DriftPlotParams& params = {});

// drift-model-<est id>.png for every matched pair, written atomically into `dir` (created).
// Throws cofusion::Error naming the file when it cannot be written.
void write_drift_plots(const ObjectsEvaluation& evaluation, const std::filesystem::path& dir,
                       const DriftPlotParams& params = {});

}  // namespace cofusion::eval
