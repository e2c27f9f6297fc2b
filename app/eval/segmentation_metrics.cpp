#include "eval/segmentation_metrics.h"

#include <Eigen/Core>
#include <algorithm>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "common/error.h"
#include "eval/assignment.h"

namespace cofusion::eval {
namespace {

cv::Mat as_u16(const cv::Mat& labels, const char* which) {
  if (labels.channels() != 1 || (labels.depth() != CV_16U && labels.depth() != CV_8U))
    throw Error(std::string("segmentation: the ") + which + " label image must be single-channel 8- or 16-bit");
  if (labels.depth() == CV_16U) return labels;
  cv::Mat out;
  labels.convertTo(out, CV_16U);
  return out;
}

bool is_image_file(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".pgm" || ext == ".ppm" || ext == ".tif" || ext == ".tiff";
}

}  // namespace

FrameSegmentation evaluate_segmentation_frame(const cv::Mat& gt_in, const cv::Mat& est_in, const SegmentationParams& params) {
  if (gt_in.empty() || est_in.empty()) throw Error("segmentation: empty label image");
  if (gt_in.size() != est_in.size())
    throw Error("segmentation: image sizes differ (ground truth " + std::to_string(gt_in.cols) + "x" +
                std::to_string(gt_in.rows) + ", estimate " + std::to_string(est_in.cols) + "x" +
                std::to_string(est_in.rows) + ")");
  const cv::Mat gt = as_u16(gt_in, "ground-truth");
  const cv::Mat est = as_u16(est_in, "estimated");

  // Compact indices for the labels present, then a dense gt x est overlap table.
  std::vector<int> gt_index(65536, -1), est_index(65536, -1);
  std::vector<int> gt_ids, est_ids;
  for (int y = 0; y < gt.rows; ++y) {
    const auto* g = gt.ptr<std::uint16_t>(y);
    const auto* e = est.ptr<std::uint16_t>(y);
    for (int x = 0; x < gt.cols; ++x) {
      if (g[x] == params.gt_ignore_label) continue;
      if (gt_index[g[x]] < 0) {
        gt_index[g[x]] = 0;
        gt_ids.push_back(g[x]);
      }
      if (e[x] != params.est_unlabelled && est_index[e[x]] < 0) {
        est_index[e[x]] = 0;
        est_ids.push_back(e[x]);
      }
    }
  }
  std::sort(gt_ids.begin(), gt_ids.end());
  std::sort(est_ids.begin(), est_ids.end());
  for (std::size_t i = 0; i < gt_ids.size(); ++i) gt_index[static_cast<std::size_t>(gt_ids[i])] = static_cast<int>(i);
  for (std::size_t j = 0; j < est_ids.size(); ++j) est_index[static_cast<std::size_t>(est_ids[j])] = static_cast<int>(j);

  const std::size_t n_gt = gt_ids.size(), n_est = est_ids.size();
  std::vector<std::size_t> overlap(n_gt * n_est, 0), gt_area(n_gt, 0), est_area(n_est, 0);
  for (int y = 0; y < gt.rows; ++y) {
    const auto* g = gt.ptr<std::uint16_t>(y);
    const auto* e = est.ptr<std::uint16_t>(y);
    for (int x = 0; x < gt.cols; ++x) {
      if (g[x] == params.gt_ignore_label) continue;
      const auto gi = static_cast<std::size_t>(gt_index[g[x]]);
      ++gt_area[gi];
      if (e[x] == params.est_unlabelled) continue;
      const auto ej = static_cast<std::size_t>(est_index[e[x]]);
      ++est_area[ej];
      ++overlap[gi * n_est + ej];
    }
  }

  Eigen::MatrixXd iou(static_cast<Eigen::Index>(n_gt), static_cast<Eigen::Index>(n_est));
  for (std::size_t i = 0; i < n_gt; ++i)
    for (std::size_t j = 0; j < n_est; ++j) {
      const double inter = static_cast<double>(overlap[i * n_est + j]);
      const double uni = static_cast<double>(gt_area[i] + est_area[j]) - inter;
      iou(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = uni > 0 ? inter / uni : 0.0;
    }
  const std::vector<int> est_of_gt = solve_max_score_assignment(iou);

  FrameSegmentation out;
  std::vector<char> est_matched(n_est, 0);
  for (std::size_t i = 0; i < n_gt; ++i) {
    LabelIou r;
    r.gt_label = gt_ids[i];
    r.gt_pixels = gt_area[i];
    const int j = i < est_of_gt.size() ? est_of_gt[i] : -1;
    if (j >= 0 && overlap[i * n_est + static_cast<std::size_t>(j)] > 0) {
      const auto ju = static_cast<std::size_t>(j);
      r.est_label = est_ids[ju];
      r.est_pixels = est_area[ju];
      r.intersection = overlap[i * n_est + ju];
      r.iou = iou(static_cast<Eigen::Index>(i), j);
      est_matched[ju] = 1;
    }
    out.gt_labels.push_back(r);
  }
  for (std::size_t j = 0; j < n_est; ++j)
    if (!est_matched[j]) out.unmatched_est_labels.push_back(est_ids[j]);
  return out;
}

SegmentationSummary summarize_segmentation(std::vector<std::string> frame_names, std::vector<FrameSegmentation> frames) {
  SegmentationSummary s;
  std::map<int, LabelSummary> by_label;
  std::map<int, double> iou_sum;
  for (const auto& f : frames) {
    for (const auto& l : f.gt_labels) {
      auto& summary = by_label[l.gt_label];
      summary.gt_label = l.gt_label;
      ++summary.frames;
      if (l.est_label >= 0) ++summary.frames_matched;
      iou_sum[l.gt_label] += l.iou;
    }
    s.unmatched_est_labels += f.unmatched_est_labels.size();
  }
  double sum_of_means = 0;
  for (auto& [label, summary] : by_label) {
    summary.mean_iou = iou_sum[label] / static_cast<double>(summary.frames);
    sum_of_means += summary.mean_iou;
    s.labels.push_back(summary);
  }
  s.mean_label_iou = s.labels.empty() ? 0.0 : sum_of_means / static_cast<double>(s.labels.size());
  s.frame_names = std::move(frame_names);
  s.frames = std::move(frames);
  return s;
}

cv::Mat read_label_image(const std::filesystem::path& path) {
  if (!std::filesystem::is_regular_file(path)) throw Error("label image " + path.string() + " does not exist");
  const cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (image.empty()) throw Error("cannot read label image " + path.string());
  if (image.channels() != 1 || (image.depth() != CV_16U && image.depth() != CV_8U))
    throw Error("label image " + path.string() + " must be single-channel 8- or 16-bit (has " +
                std::to_string(image.channels()) + " channel(s))");
  return as_u16(image, "");
}

SegmentationSummary evaluate_segmentation_dirs(const std::filesystem::path& gt_dir, const std::filesystem::path& est_dir,
                                               const SegmentationParams& params) {
  namespace fs = std::filesystem;
  for (const auto& dir : {gt_dir, est_dir})
    if (!fs::is_directory(dir)) throw Error("mask folder " + dir.string() + " does not exist");
  std::map<std::string, fs::path> est_by_stem;
  for (const auto& entry : fs::directory_iterator(est_dir))
    if (entry.is_regular_file() && is_image_file(entry.path())) est_by_stem[entry.path().stem().string()] = entry.path();
  std::vector<fs::path> gt_files;
  for (const auto& entry : fs::directory_iterator(gt_dir))
    if (entry.is_regular_file() && is_image_file(entry.path())) gt_files.push_back(entry.path());
  std::sort(gt_files.begin(), gt_files.end());
  if (gt_files.empty()) throw Error("mask folder " + gt_dir.string() + " holds no label images");

  std::vector<std::string> names;
  std::vector<FrameSegmentation> frames;
  std::size_t missing = 0;
  for (const auto& gt_path : gt_files) {
    const auto it = est_by_stem.find(gt_path.stem().string());
    if (it == est_by_stem.end()) {
      ++missing;
      continue;
    }
    try {
      frames.push_back(evaluate_segmentation_frame(read_label_image(gt_path), read_label_image(it->second), params));
    } catch (const Error& e) {
      throw Error(gt_path.string() + " vs " + it->second.string() + ": " + e.what());
    }
    names.push_back(gt_path.filename().string());
  }
  if (frames.empty())
    throw Error("no label image in " + est_dir.string() + " has the name of one in " + gt_dir.string());
  SegmentationSummary s = summarize_segmentation(std::move(names), std::move(frames));
  s.frames_without_estimate = missing;
  return s;
}

}  // namespace cofusion::eval
