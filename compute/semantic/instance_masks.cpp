#include "semantic/instance_masks.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>

#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "semantic/coco_classes.h"

namespace cofusion::semantic {
namespace {

struct Plane {
  cv::Vec3f n;  // unit normal
  float d = 0;  // n . p + d = 0 on the plane
  float distance(const cv::Vec3f& p) const { return std::abs(n.dot(p) + d); }
};

cv::Vec3f back_project(int x, int y, float z, const Intrinsics& k) {
  return {static_cast<float>((x - k.cx) / k.fx) * z, static_cast<float>((y - k.cy) / k.fy) * z, z};
}

// The plane through the most of `points` (within `tolerance`), if it holds min_fraction of them.
std::optional<Plane> ransac_plane(const std::vector<cv::Vec3f>& points, const InstanceMaskParams& p) {
  if (points.size() < 3) return std::nullopt;
  std::mt19937 rng(p.seed);
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  std::optional<Plane> best;
  size_t best_inliers = 0;
  for (int it = 0; it < p.ransac_iterations; ++it) {
    const cv::Vec3f a = points[pick(rng)], b = points[pick(rng)], c = points[pick(rng)];
    cv::Vec3f n = (b - a).cross(c - a);
    const float len = static_cast<float>(cv::norm(n));
    if (len < 1e-9f) continue;
    n /= len;
    const Plane plane{n, -n.dot(a)};
    size_t inliers = 0;
    for (const cv::Vec3f& q : points) inliers += plane.distance(q) < p.support_plane_distance_m;
    if (inliers > best_inliers) {
      best_inliers = inliers;
      best = plane;
    }
  }
  if (!best || static_cast<float>(best_inliers) < p.support_min_inlier_fraction * static_cast<float>(points.size()))
    return std::nullopt;
  return best;
}

cv::Rect to_pixels(const cv::Rect2f& box, cv::Size size) {
  const int x0 = std::clamp(static_cast<int>(std::floor(box.x)), 0, size.width);
  const int y0 = std::clamp(static_cast<int>(std::floor(box.y)), 0, size.height);
  const int x1 = std::clamp(static_cast<int>(std::ceil(box.x + box.width)), 0, size.width);
  const int y1 = std::clamp(static_cast<int>(std::ceil(box.y + box.height)), 0, size.height);
  return {x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0)};
}

// The median-depth usable pixel of the box's central part (box coordinates), or (-1, -1).
cv::Point centre_seed(const cv::Mat& depth_m, const cv::Mat& usable, const cv::Rect& box, const InstanceMaskParams& p) {
  const int cw = std::max(1, static_cast<int>(std::round(p.seed_fraction * static_cast<float>(box.width))));
  const int ch = std::max(1, static_cast<int>(std::round(p.seed_fraction * static_cast<float>(box.height))));
  const cv::Rect centre((box.width - cw) / 2, (box.height - ch) / 2, cw, ch);
  std::vector<std::pair<float, cv::Point>> candidates;
  for (int y = centre.y; y < centre.y + centre.height; ++y)
    for (int x = centre.x; x < centre.x + centre.width; ++x)
      if (usable.at<uint8_t>(y, x)) candidates.push_back({depth_m.at<float>(box.y + y, box.x + x), {x, y}});
  if (candidates.empty()) return {-1, -1};
  auto mid = candidates.begin() + static_cast<std::ptrdiff_t>(candidates.size() / 2);
  std::nth_element(candidates.begin(), mid, candidates.end(), [](const auto& a, const auto& b) {
    return a.first < b.first || (a.first == b.first && (a.second.y < b.second.y ||
                                                        (a.second.y == b.second.y && a.second.x < b.second.x)));
  });
  return mid->second;
}

// The object's pixels in `box` (CV_8UC1 of the box's size, 255 = object). Grown from the
// median-depth pixel of the box's centre, or, when `seeds` (CV_8UC1 of the box's size) is given,
// from its usable non-zero pixels; the seeds themselves are always part of the result.
cv::Mat grow_from_depth(const cv::Mat& depth_m, const cv::Mat& valid, const cv::Rect& box, const Intrinsics& k,
                        const InstanceMaskParams& p, const cv::Mat& seeds = cv::Mat()) {
  // 1. Support plane from the band around the box.
  const int mx = static_cast<int>(std::round(p.support_margin * static_cast<float>(box.width)));
  const int my = static_cast<int>(std::round(p.support_margin * static_cast<float>(box.height)));
  const cv::Rect band = cv::Rect(box.x - mx, box.y - my, box.width + 2 * mx, box.height + 2 * my) &
                        cv::Rect(0, 0, depth_m.cols, depth_m.rows);
  std::vector<cv::Point> band_pixels;
  for (int y = band.y; y < band.y + band.height; ++y)
    for (int x = band.x; x < band.x + band.width; ++x)
      if (!box.contains({x, y}) && valid.at<uint8_t>(y, x)) band_pixels.emplace_back(x, y);
  std::vector<cv::Vec3f> points;
  const size_t step = std::max<size_t>(1, band_pixels.size() / static_cast<size_t>(std::max(1, p.ransac_max_points)));
  for (size_t i = 0; i < band_pixels.size(); i += step) {
    const cv::Point q = band_pixels[i];
    points.push_back(back_project(q.x, q.y, depth_m.at<float>(q), k));
  }
  const std::optional<Plane> support = ransac_plane(points, p);

  // Usable pixels of the box: valid and not on the support plane.
  cv::Mat usable(box.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < box.height; ++y)
    for (int x = 0; x < box.width; ++x) {
      const int gx = box.x + x, gy = box.y + y;
      if (!valid.at<uint8_t>(gy, gx)) continue;
      if (support && support->distance(back_project(gx, gy, depth_m.at<float>(gy, gx), k)) < p.support_plane_distance_m)
        continue;
      usable.at<uint8_t>(y, x) = 1;
    }

  cv::Mat mask(box.size(), CV_8UC1, cv::Scalar(0));
  std::vector<cv::Point> stack;
  if (!seeds.empty()) {
    // Grow from the seeds' core (a soft segmentation's rim may lie on the background) and only
    // within seed_depth_window_m of their median depth (a person's legs, not the wall behind).
    cv::Mat core;
    const int r = p.seed_erosion_px;
    cv::erode(seeds, core, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
    std::vector<float> depths;
    for (int y = 0; y < box.height; ++y)
      for (int x = 0; x < box.width; ++x)
        if (core.at<uint8_t>(y, x) && usable.at<uint8_t>(y, x)) {
          stack.emplace_back(x, y);
          mask.at<uint8_t>(y, x) = 255;
          depths.push_back(depth_m.at<float>(box.y + y, box.x + x));
        }
    if (depths.empty()) return seeds.clone();
    auto mid = depths.begin() + static_cast<std::ptrdiff_t>(depths.size() / 2);
    std::nth_element(depths.begin(), mid, depths.end());
    for (int y = 0; y < box.height; ++y)
      for (int x = 0; x < box.width; ++x)
        if (std::abs(depth_m.at<float>(box.y + y, box.x + x) - *mid) > p.seed_depth_window_m) usable.at<uint8_t>(y, x) = 0;
  } else {
    // 2. Seed: the median-depth usable pixel of the central part.
    const cv::Point seed = centre_seed(depth_m, usable, box, p);
    if (seed.x < 0) return mask;
    stack.push_back(seed);
    mask.at<uint8_t>(seed) = 255;
  }

  // 3. Region growing over small depth steps.
  while (!stack.empty()) {
    const cv::Point q = stack.back();
    stack.pop_back();
    const float dq = depth_m.at<float>(box.y + q.y, box.x + q.x);
    const cv::Point next[4] = {{q.x - 1, q.y}, {q.x + 1, q.y}, {q.x, q.y - 1}, {q.x, q.y + 1}};
    for (const cv::Point& r : next) {
      if (r.x < 0 || r.y < 0 || r.x >= box.width || r.y >= box.height) continue;
      if (mask.at<uint8_t>(r) || !usable.at<uint8_t>(r)) continue;
      if (std::abs(depth_m.at<float>(box.y + r.y, box.x + r.x) - dq) >= p.max_relative_depth_step * dq) continue;
      mask.at<uint8_t>(r) = 255;
      stack.push_back(r);
    }
  }
  if (!seeds.empty()) mask.setTo(255, seeds);
  return mask;
}

// The share of a mask's pixels (CV_8UC1) whose person probability (CV_32FC1, same size) is above
// `threshold`; 0 for an empty mask.
double person_share(const cv::Mat& mask, const cv::Mat& probability, float threshold) {
  int pixels = 0, person = 0;
  for (int y = 0; y < mask.rows; ++y)
    for (int x = 0; x < mask.cols; ++x)
      if (mask.at<uint8_t>(y, x)) {
        ++pixels;
        person += probability.at<float>(y, x) > threshold;
      }
  return pixels == 0 ? 0.0 : double(person) / double(pixels);
}

}  // namespace

InstanceMasks instance_masks(const std::vector<Detection>& detections, const cv::Mat& depth_m,
                             const Intrinsics& intrinsics, const InstanceMaskParams& params,
                             const cv::Mat& person_probability) {
  if (depth_m.empty() || depth_m.type() != CV_32FC1) throw Error("instance_masks: depth must be CV_32FC1 metres");
  if (!person_probability.empty() &&
      (person_probability.type() != CV_32FC1 || person_probability.size() != depth_m.size()))
    throw Error("instance_masks: the person probability must be CV_32FC1 of the depth's size");
  InstanceMasks out;
  out.ids = cv::Mat(depth_m.size(), CV_16UC1, cv::Scalar(0));
  cv::Mat valid(depth_m.size(), CV_8UC1);
  for (int y = 0; y < depth_m.rows; ++y)
    for (int x = 0; x < depth_m.cols; ++x) {
      const float d = depth_m.at<float>(y, x);
      valid.at<uint8_t>(y, x) = std::isfinite(d) && d >= params.min_depth_m && d <= params.max_depth_m;
    }

  std::vector<size_t> order(detections.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return detections[a].score > detections[b].score; });
  for (const size_t i : order) {
    const Detection& det = detections[i];
    const cv::Rect box = to_pixels(det.box_px, depth_m.size());
    if (box.area() == 0) continue;
    cv::Mat mask;
    int class_id = det.class_id;
    std::string class_name = det.class_name;
    if (det.class_id == kCocoPersonClass && !person_probability.empty()) {
      cv::compare(person_probability(box), params.person_probability, mask, cv::CMP_GT);
      if (params.grow_people_over_depth) mask = grow_from_depth(depth_m, valid, box, intrinsics, params, mask);
    } else {
      mask = grow_from_depth(depth_m, valid, box, intrinsics, params);
      if (!person_probability.empty() && person_share(mask, person_probability(box), params.person_probability) >=
                                             params.person_override_fraction) {
        class_id = kCocoPersonClass;
        class_name = std::string(kCocoClassNames[kCocoPersonClass]);
      }
    }
    if (out.instances.size() >= 65535) break;
    const uint16_t id = static_cast<uint16_t>(out.instances.size() + 1);
    int pixels = 0;
    cv::Mat ids_box = out.ids(box);
    for (int y = 0; y < box.height; ++y)
      for (int x = 0; x < box.width; ++x) pixels += mask.at<uint8_t>(y, x) && ids_box.at<uint16_t>(y, x) == 0;
    if (pixels < params.min_pixels || static_cast<float>(pixels) < params.min_box_fraction * static_cast<float>(box.area()))
      continue;
    for (int y = 0; y < box.height; ++y)
      for (int x = 0; x < box.width; ++x)
        if (mask.at<uint8_t>(y, x) && ids_box.at<uint16_t>(y, x) == 0) ids_box.at<uint16_t>(y, x) = id;
    out.instances.push_back({id, class_id, class_name, det.score, det.box_px, pixels});
  }
  return out;
}

}  // namespace cofusion::semantic
