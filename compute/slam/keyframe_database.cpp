#include "slam/keyframe_database.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

#include "common/error.h"
#include "common/se3.h"

namespace cofusion::slam {

namespace {

// The best match of each live descriptor in the keyframe's that passes Lowe's ratio test.
std::vector<cv::DMatch> ratio_matches(const cv::Mat& live, const cv::Mat& keyframe, double ratio) {
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> matches;
  matcher.knnMatch(live, keyframe, matches, 2);
  std::vector<cv::DMatch> good;
  for (const auto& m : matches)
    if (m.size() == 2 && m[0].distance < ratio * m[1].distance) good.push_back(m[0]);
  return good;
}

// RANSAC EPnP: the points' frame in the camera (rvec, tvec) and the inlier matches; nullopt with
// fewer than min_inliers.
struct PnpFit {
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
};
std::optional<PnpFit> ransac_pnp(const std::vector<cv::Point3f>& object, const std::vector<cv::Point2f>& image,
                                 const cv::Matx33d& K, double max_reprojection_px, int min_inliers) {
  if (int(object.size()) < min_inliers) return std::nullopt;
  PnpFit fit;
  if (!cv::solvePnPRansac(object, image, K, cv::noArray(), fit.rvec, fit.tvec, false, 200, float(max_reprojection_px), 0.99,
                          fit.inliers, cv::SOLVEPNP_EPNP) ||
      int(fit.inliers.size()) < min_inliers)
    return std::nullopt;
  return fit;
}

Eigen::Isometry3d isometry(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = R(r, c);
    T.translation()(r) = tvec.at<double>(r);
  }
  return T;
}

}  // namespace

KeyframeDatabase::KeyframeDatabase(const KeyframeParams& params) : params_(params) {
  const auto bad = [](const char* why) { throw Error(std::string("invalid keyframe parameter: ") + why); };
  if (params.cols < 1 || params.rows < 1) bad("cols and rows must be >= 1");
  if (!(params.min_valid_fraction > 0 && params.min_valid_fraction <= 1)) bad("min_valid_fraction must be in (0, 1]");
  if (!(params.depth_weight_per_m >= 0)) bad("depth_weight_per_m must be >= 0");
  if (!(params.min_overlap_fraction >= 0 && params.min_overlap_fraction <= 1)) bad("min_overlap_fraction must be in [0, 1]");
  if (!(params.min_translation_m >= 0) || !(params.min_rotation_deg >= 0)) bad("novelty thresholds must be >= 0");
  if (params.max_keyframes < 1) bad("max_keyframes must be >= 1");
}

FrameEncoding KeyframeDatabase::encode(const uint8_t* rgb, const float* depth_m, int width, int height) const {
  const int cols = params_.cols, rows = params_.rows;
  const size_t blocks = size_t(cols) * size_t(rows);
  std::vector<double> intensity(blocks, 0.0), depth(blocks, 0.0);
  std::vector<int> pixels(blocks, 0), valid(blocks, 0);
  for (int y = 0; y < height; ++y) {
    const size_t by = size_t(std::min(rows - 1, y * rows / height));
    for (int x = 0; x < width; ++x) {
      const size_t b = by * size_t(cols) + size_t(std::min(cols - 1, x * cols / width));
      const size_t i = size_t(y) * size_t(width) + size_t(x);
      const uint8_t* c = rgb + 3 * i;
      intensity[b] += (double(c[0]) + double(c[1]) + double(c[2])) / 3.0;
      ++pixels[b];
      const float d = depth_m[i];
      if (d > 0.0f && std::isfinite(d)) depth[b] += d, ++valid[b];
    }
  }
  FrameEncoding e;
  e.intensity.resize(blocks);
  e.depth_m.resize(blocks);
  double mean = 0, sq = 0;
  for (size_t b = 0; b < blocks; ++b) {
    const double v = pixels[b] > 0 ? intensity[b] / pixels[b] : 0.0;
    intensity[b] = v, mean += v, sq += v * v;
    e.depth_m[b] = pixels[b] > 0 && valid[b] >= params_.min_valid_fraction * pixels[b] ? float(depth[b] / valid[b]) : 0.0f;
  }
  mean /= double(blocks);
  const double stddev = std::sqrt(std::max(0.0, sq / double(blocks) - mean * mean));
  // A uniform image (a covered lens) has no contrast to normalise: its blocks stay at zero.
  for (size_t b = 0; b < blocks; ++b) e.intensity[b] = stddev > 1e-6 ? float((intensity[b] - mean) / stddev) : 0.0f;
  return e;
}

double KeyframeDatabase::dissimilarity(const FrameEncoding& a, const FrameEncoding& b) const {
  const size_t blocks = a.intensity.size();
  if (blocks == 0 || b.intensity.size() != blocks) return std::numeric_limits<double>::infinity();
  double di = 0, dd = 0;
  size_t both = 0;
  for (size_t k = 0; k < blocks; ++k) {
    di += std::abs(double(a.intensity[k]) - double(b.intensity[k]));
    if (a.depth_m[k] > 0.0f && b.depth_m[k] > 0.0f) dd += std::abs(double(a.depth_m[k]) - double(b.depth_m[k])), ++both;
  }
  if (double(both) < params_.min_overlap_fraction * double(blocks)) return std::numeric_limits<double>::infinity();
  return di / double(blocks) + params_.depth_weight_per_m * dd / double(both);
}

bool KeyframeDatabase::add_if_novel(const FrameEncoding& encoding, const std::function<FrameFeatures()>& features,
                                    const Eigen::Isometry3d& T_world_camera) {
  for (const Keyframe& k : keyframes_) {
    const Eigen::Isometry3d d = k.T_world_camera.inverse() * T_world_camera;
    if (d.translation().norm() < params_.min_translation_m &&
        rotation_angle_rad(d) * 180.0 / std::numbers::pi < params_.min_rotation_deg)
      return false;
  }
  if (int(keyframes_.size()) >= params_.max_keyframes) keyframes_.erase(keyframes_.begin());
  keyframes_.push_back({encoding, features(), T_world_camera});
  return true;
}

FrameFeatures KeyframeDatabase::features(const uint8_t* rgb, const float* depth_m, const Intrinsics& k) const {
  cv::Mat gray(k.height, k.width, CV_8UC1);
  for (int i = 0; i < k.width * k.height; ++i)
    gray.data[i] = static_cast<uint8_t>((int(rgb[3 * i]) + int(rgb[3 * i + 1]) + int(rgb[3 * i + 2])) / 3);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  cv::ORB::create(params_.orb_features)->detectAndCompute(gray, cv::noArray(), keypoints, descriptors);
  FrameFeatures f;
  for (size_t j = 0; j < keypoints.size(); ++j) {
    const cv::Point2f& u = keypoints[j].pt;
    const int x = std::clamp(int(std::lround(u.x)), 0, k.width - 1), y = std::clamp(int(std::lround(u.y)), 0, k.height - 1);
    const float z = depth_m[size_t(y) * size_t(k.width) + size_t(x)];
    if (!(z > 0.0f) || !std::isfinite(z)) continue;
    f.pixels.push_back(u);
    f.points_camera.emplace_back(float((u.x - k.cx) / k.fx) * z, float((u.y - k.cy) / k.fy) * z, z);
    f.descriptors.push_back(descriptors.row(int(j)));
  }
  return f;
}

// The keyframes whose features are matched: the most similar by encoding, and the newest (the
// camera was there last).
std::vector<size_t> KeyframeDatabase::pnp_keyframes(const FrameEncoding& encoding) const {
  std::vector<std::pair<double, size_t>> scored;
  for (size_t i = 0; i < keyframes_.size(); ++i) scored.emplace_back(dissimilarity(encoding, keyframes_[i].encoding), i);
  std::sort(scored.begin(), scored.end());
  std::vector<size_t> chosen;
  for (size_t i = 0; i < scored.size() && int(chosen.size()) < params_.pnp_similar_keyframes; ++i) chosen.push_back(scored[i].second);
  for (int i = 0; i < params_.pnp_newest_keyframes && i < int(keyframes_.size()); ++i) {
    const size_t newest = keyframes_.size() - 1 - size_t(i);
    if (std::find(chosen.begin(), chosen.end(), newest) == chosen.end()) chosen.push_back(newest);
  }
  return chosen;
}

std::optional<KeyframePose> KeyframeDatabase::pnp_pose(const FrameEncoding& encoding, const FrameFeatures& live,
                                                       const Intrinsics& k) const {
  if (live.descriptors.empty()) return std::nullopt;
  // Every chosen keyframe's matches at once, their points in world coordinates: one pose that
  // every keyframe's points support, which averages out the keyframes' own pose errors.
  std::vector<cv::Point3f> object;  // world
  std::vector<cv::Point2f> image;
  for (size_t i : pnp_keyframes(encoding)) {
    const Keyframe& kf = keyframes_[i];
    if (kf.features.descriptors.empty()) continue;
    for (const cv::DMatch& m : ratio_matches(live.descriptors, kf.features.descriptors, params_.match_ratio)) {
      const cv::Point3f& p = kf.features.points_camera[size_t(m.trainIdx)];
      const Eigen::Vector3d w = kf.T_world_camera * Eigen::Vector3d(p.x, p.y, p.z);
      object.emplace_back(float(w.x()), float(w.y()), float(w.z()));
      image.push_back(live.pixels[size_t(m.queryIdx)]);
    }
  }
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  std::optional<PnpFit> fit = ransac_pnp(object, image, K, params_.max_reprojection_px, params_.min_pnp_inliers);
  if (!fit) return std::nullopt;
  std::vector<cv::Point3f> object_in;
  std::vector<cv::Point2f> image_in;
  for (int i : fit->inliers) object_in.push_back(object[size_t(i)]), image_in.push_back(image[size_t(i)]);
  cv::solvePnPRefineLM(object_in, image_in, K, cv::noArray(), fit->rvec, fit->tvec);  // EPnP's minimal fit, refined on every inlier
  return KeyframePose{isometry(fit->rvec, fit->tvec).inverse(), int(fit->inliers.size())};
}

std::vector<Eigen::Isometry3d> KeyframeDatabase::pnp_poses(const FrameEncoding& encoding, const FrameFeatures& live,
                                                          const Intrinsics& k) const {
  if (live.descriptors.empty()) return {};
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  std::vector<std::pair<int, Eigen::Isometry3d>> poses;  // (inliers, T_world_live)
  for (size_t i : pnp_keyframes(encoding)) {
    const Keyframe& kf = keyframes_[i];
    if (kf.features.descriptors.rows < params_.min_pnp_inliers) continue;
    std::vector<cv::Point3f> object;
    std::vector<cv::Point2f> image;
    for (const cv::DMatch& m : ratio_matches(live.descriptors, kf.features.descriptors, params_.match_ratio)) {
      object.push_back(kf.features.points_camera[size_t(m.trainIdx)]);
      image.push_back(live.pixels[size_t(m.queryIdx)]);
    }
    const std::optional<PnpFit> fit = ransac_pnp(object, image, K, params_.max_reprojection_px, params_.min_pnp_inliers);
    if (fit) poses.emplace_back(int(fit->inliers.size()), kf.T_world_camera * isometry(fit->rvec, fit->tvec).inverse());
  }
  std::stable_sort(poses.begin(), poses.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<Eigen::Isometry3d> out;
  for (const auto& [n, T] : poses) out.push_back(T);
  return out;
}

std::vector<Eigen::Isometry3d> KeyframeDatabase::nearest(const FrameEncoding& encoding, int count) const {
  std::vector<std::pair<double, size_t>> scored;
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    const double d = dissimilarity(encoding, keyframes_[k].encoding);
    if (std::isfinite(d)) scored.emplace_back(d, k);
  }
  // Ties (identical encodings) keep the newer keyframe first: it was made with the newer map.
  std::sort(scored.begin(), scored.end(), [](const auto& x, const auto& y) {
    return x.first != y.first ? x.first < y.first : x.second > y.second;
  });
  std::vector<Eigen::Isometry3d> out;
  for (size_t k = 0; k < scored.size() && int(out.size()) < count; ++k) out.push_back(keyframes_[scored[k].second].T_world_camera);
  return out;
}

}  // namespace cofusion::slam
