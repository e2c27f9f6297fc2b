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

// The band around the box searched for the support plane (the box grown by support_margin on each
// side, within the image); the concave cut measures how far a part of the surface reaches into it.
cv::Rect surroundings(const cv::Rect& box, cv::Size image, const InstanceMaskParams& p) {
  const int mx = static_cast<int>(std::round(p.support_margin * static_cast<float>(box.width)));
  const int my = static_cast<int>(std::round(p.support_margin * static_cast<float>(box.height)));
  return cv::Rect(box.x - mx, box.y - my, box.width + 2 * mx, box.height + 2 * my) & cv::Rect({0, 0}, image);
}

// The plane most of the band's valid pixels outside the box lie on (step 1), if any.
std::optional<Plane> support_plane(const cv::Mat& depth_m, const cv::Mat& valid, const cv::Rect& box,
                                   const cv::Rect& band, const Intrinsics& k, const InstanceMaskParams& p) {
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
  return ransac_plane(points, p);
}

// Valid pixels of `area` (image coordinates) not on the support plane: CV_8UC1 of the area's size.
cv::Mat usable_pixels(const cv::Mat& depth_m, const cv::Mat& valid, const cv::Rect& area,
                      const std::optional<Plane>& support, const Intrinsics& k, const InstanceMaskParams& p) {
  cv::Mat usable(area.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < area.height; ++y)
    for (int x = 0; x < area.width; ++x) {
      const int gx = area.x + x, gy = area.y + y;
      if (!valid.at<uint8_t>(gy, gx)) continue;
      if (support && support->distance(back_project(gx, gy, depth_m.at<float>(gy, gx), k)) < p.support_plane_distance_m)
        continue;
      usable.at<uint8_t>(y, x) = 1;
    }
  return usable;
}

// Calls visit(r) for each 4-neighbour r of `q` (coordinates in `area`, image coordinates) inside
// the area whose depth differs from q's by less than max_relative_depth_step x q's depth.
template <typename Visit>
void for_each_continuous_neighbour(const cv::Mat& depth_m, const cv::Rect& area, cv::Point q, const InstanceMaskParams& p,
                                   Visit&& visit) {
  const float dq = depth_m.at<float>(area.y + q.y, area.x + q.x);
  const cv::Point next[4] = {{q.x - 1, q.y}, {q.x + 1, q.y}, {q.x, q.y - 1}, {q.x, q.y + 1}};
  for (const cv::Point& r : next) {
    if (r.x < 0 || r.y < 0 || r.x >= area.width || r.y >= area.height) continue;
    if (std::abs(depth_m.at<float>(area.y + r.y, area.x + r.x) - dq) >= p.max_relative_depth_step * dq) continue;
    visit(r);
  }
}

// Region growing (step 3) in `area` (image coordinates) from the pixels on `stack` (already set in
// `mask`, CV_8UC1 of the area's size) over continuous-depth 4-neighbours that are usable.
void grow(const cv::Mat& depth_m, const cv::Rect& area, const cv::Mat& usable, const InstanceMaskParams& p,
          std::vector<cv::Point> stack, cv::Mat& mask) {
  while (!stack.empty()) {
    const cv::Point q = stack.back();
    stack.pop_back();
    for_each_continuous_neighbour(depth_m, area, q, p, [&](cv::Point r) {
      if (mask.at<uint8_t>(r) || !usable.at<uint8_t>(r)) return;
      mask.at<uint8_t>(r) = 255;
      stack.push_back(r);
    });
  }
}

// The surface's unit normals in `area` (image coordinates; CV_32FC3, facing the camera, zero where
// unknown) from the depth averaged over normal_window_px (valid readings only) and differences
// over fold_probe_px either way, and the averaged points (CV_32FC3).
void normals_and_points(const cv::Mat& depth_m, const cv::Mat& valid, const cv::Rect& area, const Intrinsics& k,
                        const InstanceMaskParams& p, cv::Mat& normals, cv::Mat& points) {
  cv::Mat weight, sum;
  valid(area).convertTo(weight, CV_32F);
  cv::Mat depth = depth_m(area).clone();
  depth.setTo(0.f, valid(area) == 0);
  const cv::Size window(p.normal_window_px, p.normal_window_px);
  cv::boxFilter(depth, sum, CV_32F, window, {-1, -1}, false, cv::BORDER_CONSTANT);
  cv::boxFilter(weight, weight, CV_32F, window, {-1, -1}, false, cv::BORDER_CONSTANT);
  const float min_weight = 0.5f * static_cast<float>(window.area());
  points = cv::Mat(area.size(), CV_32FC3, cv::Scalar::all(0));
  for (int y = 0; y < area.height; ++y)
    for (int x = 0; x < area.width; ++x)
      if (valid.at<uint8_t>(area.y + y, area.x + x) && weight.at<float>(y, x) >= min_weight) {
        const float raw = depth.at<float>(y, x), mean = sum.at<float>(y, x) / weight.at<float>(y, x);
        // An average across a depth step lies on neither side: no point there.
        if (std::abs(mean - raw) < p.max_relative_depth_step * raw) points.at<cv::Vec3f>(y, x) = back_project(area.x + x, area.y + y, mean, k);
      }
  normals = cv::Mat(area.size(), CV_32FC3, cv::Scalar::all(0));
  const int s = p.fold_probe_px;
  for (int y = s; y < area.height - s; ++y)
    for (int x = s; x < area.width - s; ++x) {
      const cv::Vec3f &l = points.at<cv::Vec3f>(y, x - s), &r = points.at<cv::Vec3f>(y, x + s);
      const cv::Vec3f &u = points.at<cv::Vec3f>(y - s, x), &d = points.at<cv::Vec3f>(y + s, x);
      const float z = points.at<cv::Vec3f>(y, x)[2], max_step = p.max_relative_depth_step * static_cast<float>(s) * z;
      if (z == 0 || l[2] == 0 || r[2] == 0 || u[2] == 0 || d[2] == 0) continue;
      // Only over continuous depth: a depth step is an edge of its own, not a fold.
      if (std::abs(l[2] - z) > max_step || std::abs(r[2] - z) > max_step || std::abs(u[2] - z) > max_step ||
          std::abs(d[2] - z) > max_step)
        continue;
      cv::Vec3f n = (r - l).cross(d - u);
      const float len = static_cast<float>(cv::norm(n));
      if (len < 1e-12f) continue;
      n /= len;
      if (n.dot(points.at<cv::Vec3f>(y, x)) > 0) n = -n;
      normals.at<cv::Vec3f>(y, x) = n;
    }
}

// Pixels of `area` where the surface folds concavely (CV_8UC1, 255 = fold): the normals
// fold_probe_px to either side (along a row or a column) differ by more than fold_angle_deg and
// turn towards each other, (n1 - n2) . (p1 - p2) < 0 (Stein et al.'s convexity criterion, as
// MaskFusion's geometric edges use it). An object meets what it stands on or leans against there.
// Pixels of unknown normal next to a fold continue it.
cv::Mat concave_folds(const cv::Mat& depth_m, const cv::Mat& valid, const cv::Rect& area, const Intrinsics& k,
                      const InstanceMaskParams& p) {
  cv::Mat normals, points;
  normals_and_points(depth_m, valid, area, k, p, normals, points);
  const float min_cos = std::cos(p.fold_angle_deg * static_cast<float>(CV_PI) / 180.f);
  cv::Mat folds(area.size(), CV_8UC1, cv::Scalar(0));
  const int s = p.fold_probe_px;
  const auto folds_between = [&](cv::Point a, cv::Point b) {
    const cv::Vec3f &n1 = normals.at<cv::Vec3f>(a), &n2 = normals.at<cv::Vec3f>(b);
    if (n1 == cv::Vec3f() || n2 == cv::Vec3f() || n1.dot(n2) > min_cos) return false;
    return (n1 - n2).dot(points.at<cv::Vec3f>(a) - points.at<cv::Vec3f>(b)) < 0;
  };
  for (int y = s; y < area.height - s; ++y)
    for (int x = s; x < area.width - s; ++x)
      if (folds_between({x - s, y}, {x + s, y}) || folds_between({x, y - s}, {x, y + s})) folds.at<uint8_t>(y, x) = 255;
  // Where a fold runs into a depth edge or the area's border the normals are unknown for up to
  // fold_probe_px + normal_window_px pixels: the fold goes on through them (a dilation confined to
  // them), so that the parts it separates stay apart.
  cv::Mat unknown, near_fold;
  cv::inRange(normals, cv::Scalar::all(0), cv::Scalar::all(0), unknown);
  const cv::Mat step = cv::getStructuringElement(cv::MORPH_RECT, {3, 3});
  for (int i = 0; i < s + p.normal_window_px; ++i) {
    cv::dilate(folds, near_fold, step);
    folds |= near_fold & unknown;
  }
  return folds;
}

// Gives each pixel of `region` (CV_8UC1) that `labels` (CV_32S, 0 = none) leaves unlabelled the
// label that reaches it first, growing all labels at once over `region`'s 4-neighbours within
// max_relative_depth_step (a geodesic Voronoi partition, as a watershed on flat ground).
void claim_by_nearest(const cv::Mat& depth_m, const cv::Rect& area, const cv::Mat& region,
                      const InstanceMaskParams& p, cv::Mat& labels) {
  std::vector<cv::Point> ring, next_ring;
  for (int y = 0; y < area.height; ++y)
    for (int x = 0; x < area.width; ++x)
      if (labels.at<int>(y, x)) ring.emplace_back(x, y);
  while (!ring.empty()) {
    for (const cv::Point& q : ring)
      for_each_continuous_neighbour(depth_m, area, q, p, [&](cv::Point r) {
        if (labels.at<int>(r) || !region.at<uint8_t>(r)) return;
        labels.at<int>(r) = labels.at<int>(q);
        next_ring.push_back(r);
      });
    ring.swap(next_ring);
    next_ring.clear();
  }
}

// Step 3 with the concave cut: `reach` (CV_8UC1 of `band`'s size) is what grew from the seed over
// small depth steps. Concave folds split it into parts (the fold pixels go to the part nearest to
// them); a part that reaches beyond the box for more than fold_part_outside_fraction of its
// pixels is what the object stands on or leans against and is dropped, unless the seed lies in it.
// Parts inside the box stay (a chair's backrest and seat meet at a concave fold too).
cv::Mat cut_at_concave_folds(const cv::Mat& depth_m, const cv::Mat& valid, const cv::Rect& box, const cv::Rect& band,
                             const Intrinsics& k, const InstanceMaskParams& p, const cv::Mat& reach, cv::Point seed) {
  const cv::Mat folds = concave_folds(depth_m, valid, band, k, p);
  cv::Mat parts;
  const int n = cv::connectedComponents(reach & ~folds, parts, 4, CV_32S);
  claim_by_nearest(depth_m, band, reach & folds, p, parts);
  std::vector<int> inside(static_cast<size_t>(n), 0), total(static_cast<size_t>(n), 0);
  const cv::Rect box_in_band(box.tl() - band.tl(), box.size());
  for (int y = 0; y < band.height; ++y)
    for (int x = 0; x < band.width; ++x) {
      const auto label = static_cast<size_t>(parts.at<int>(y, x));
      ++total[label];
      inside[label] += box_in_band.contains({x, y});
    }
  const int seed_label = parts.at<int>(seed);
  cv::Mat kept(box.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < box.height; ++y)
    for (int x = 0; x < box.width; ++x) {
      const int label = parts.at<int>(box_in_band.y + y, box_in_band.x + x);
      if (label == 0) continue;
      const float outside = 1.f - float(inside[size_t(label)]) / float(total[size_t(label)]);
      if (label == seed_label || outside <= p.fold_part_outside_fraction) kept.at<uint8_t>(y, x) = 255;
    }
  return kept;
}

// The object's pixels in `box` (CV_8UC1 of the box's size, 255 = object): grown from the
// median-depth pixel of the box's centre over the surroundings and cut at concave folds.
cv::Mat object_from_depth(const cv::Mat& depth_m, const cv::Mat& valid, const cv::Rect& box, const Intrinsics& k,
                          const InstanceMaskParams& p) {
  const cv::Rect band = surroundings(box, depth_m.size(), p);
  const std::optional<Plane> support = support_plane(depth_m, valid, box, band, k, p);
  const cv::Mat usable = usable_pixels(depth_m, valid, band, support, k, p);
  const cv::Rect box_in_band(box.tl() - band.tl(), box.size());
  const cv::Point seed = centre_seed(depth_m, usable(box_in_band), box, p);
  if (seed.x < 0) return cv::Mat(box.size(), CV_8UC1, cv::Scalar(0));
  const cv::Point seed_in_band = seed + box_in_band.tl();
  cv::Mat reach(band.size(), CV_8UC1, cv::Scalar(0));
  reach.at<uint8_t>(seed_in_band) = 255;
  grow(depth_m, band, usable, p, {seed_in_band}, reach);
  if (p.fold_angle_deg <= 0) return reach(box_in_band).clone();
  return cut_at_concave_folds(depth_m, valid, box, band, k, p, reach, seed_in_band);
}

// A person's pixels in `box` (CV_8UC1 of the box's size): the segmenter's `seeds` (same size)
// grown over depth within the box, from their core (a soft segmentation's rim may lie on the
// background) and only within seed_depth_window_m of their median depth (a person's legs, not the
// wall behind); the seeds themselves are always part of the result.
cv::Mat person_from_depth(const cv::Mat& depth_m, const cv::Mat& valid, const cv::Rect& box, const Intrinsics& k,
                          const InstanceMaskParams& p, const cv::Mat& seeds) {
  const cv::Rect band = surroundings(box, depth_m.size(), p);
  const std::optional<Plane> support = support_plane(depth_m, valid, box, band, k, p);
  cv::Mat usable = usable_pixels(depth_m, valid, box, support, k, p);
  cv::Mat core;
  const int r = p.seed_erosion_px;
  cv::erode(seeds, core, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
  cv::Mat mask(box.size(), CV_8UC1, cv::Scalar(0));
  std::vector<cv::Point> stack;
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
  grow(depth_m, box, usable, p, std::move(stack), mask);
  mask.setTo(255, seeds);
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
      if (params.grow_people_over_depth) mask = person_from_depth(depth_m, valid, box, intrinsics, params, mask);
    } else {
      mask = object_from_depth(depth_m, valid, box, intrinsics, params);
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
