#include "slam/semantic_masks.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "common/error.h"

namespace cofusion::slam {

const char* to_string(SegmentationMode mode) {
  switch (mode) {
    case SegmentationMode::kMotion: return "motion";
    case SegmentationMode::kSemantic: return "semantic";
    case SegmentationMode::kBoth: return "both";
  }
  return "?";
}

std::optional<SegmentationMode> parse_segmentation_mode(const std::string& text) {
  for (const SegmentationMode m : {SegmentationMode::kMotion, SegmentationMode::kSemantic, SegmentationMode::kBoth})
    if (text == to_string(m)) return m;
  return std::nullopt;
}

void check_semantic_frame(const SemanticFrame& frame, size_t pixels) {
  if (frame.ids.size() != pixels)
    throw Error("semantic masks have " + std::to_string(frame.ids.size()) + " pixels, the frame " +
                std::to_string(pixels));
}

SemanticFrame carry_semantic_frame(const SemanticFrame& made, const float* depth_m, const Intrinsics& intrinsics,
                                   const Eigen::Isometry3d& T_made_current, const std::vector<uint8_t>& owner,
                                   const std::vector<SlotMotion>& object_motions) {
  const int width = intrinsics.width, height = intrinsics.height;
  check_semantic_frame(made, size_t(width) * size_t(height));
  if (!owner.empty() && owner.size() != made.ids.size())
    throw Error("carry_semantic_frame: the owner map has " + std::to_string(owner.size()) + " pixels, the masks " +
                std::to_string(made.ids.size()));
  // Per slot the motion its pixels follow (the camera's where no object's is given).
  std::vector<const Eigen::Isometry3d*> motion_of(256, &T_made_current);
  for (const SlotMotion& m : object_motions) motion_of[m.slot] = &m.T_made_current;
  SemanticFrame carried;
  carried.classes = made.classes;
  carried.age_frames = made.age_frames;
  carried.repeated = made.repeated;
  carried.ids.assign(made.ids.size(), 0);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const size_t i = size_t(v) * size_t(width) + size_t(u);
      const double z = depth_m[i];
      if (!(z > 0)) continue;
      const Eigen::Vector3d p_current((u - intrinsics.cx) / intrinsics.fx * z, (v - intrinsics.cy) / intrinsics.fy * z, z);
      const Eigen::Vector3d p_made = (owner.empty() ? T_made_current : *motion_of[owner[i]]) * p_current;
      if (!(p_made.z() > 0)) continue;
      const double x = intrinsics.fx * p_made.x() / p_made.z() + intrinsics.cx;
      const double y = intrinsics.fy * p_made.y() / p_made.z() + intrinsics.cy;
      if (!(x > -0.5 && x < width - 0.5 && y > -0.5 && y < height - 0.5)) continue;  // NaN too
      carried.ids[i] = made.ids[size_t(std::lround(y)) * size_t(width) + size_t(std::lround(x))];
    }
  return carried;
}

bool is_excluded_class(const SemanticParams& params, const std::string& class_name) {
  return std::find(params.exclude.begin(), params.exclude.end(), class_name) != params.exclude.end();
}

bool is_modelled_class(const SemanticParams& params, const std::string& class_name) {
  if (is_excluded_class(params, class_name)) return false;
  return params.classes.empty() || std::find(params.classes.begin(), params.classes.end(), class_name) != params.classes.end();
}

size_t excluded_pixels(const SemanticFrame& frame, const SemanticParams& params, std::vector<uint8_t>& excluded) {
  excluded.clear();
  std::vector<uint16_t> excluded_ids;
  for (const auto& [id, name] : frame.classes)
    if (id != 0 && is_excluded_class(params, name)) excluded_ids.push_back(id);
  if (excluded_ids.empty()) return 0;
  // Per id lookup (ids are 16-bit): a table of 64 Ki flags.
  std::vector<uint8_t> is_excluded(0x10000, 0);
  for (uint16_t id : excluded_ids) is_excluded[id] = 1;
  excluded.assign(frame.ids.size(), 0);
  size_t count = 0;
  for (size_t i = 0; i < frame.ids.size(); ++i) count += excluded[i] = is_excluded[frame.ids[i]];
  if (count == 0) excluded.clear();
  return count;
}

size_t grow_mask(std::vector<uint8_t>& mask, int width, int radius_px) {
  if (mask.empty() || width <= 0 || mask.size() % size_t(width) != 0)
    throw Error("grow_mask: mask size is not a multiple of the width");
  cv::Mat image(int(mask.size() / size_t(width)), width, CV_8UC1, mask.data());  // shares mask's pixels
  if (radius_px > 0)
    cv::dilate(image, image, cv::getStructuringElement(cv::MORPH_RECT, {2 * radius_px + 1, 2 * radius_px + 1}),
               {-1, -1}, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  return size_t(cv::countNonZero(image));
}

bool mark_excluded(const std::vector<uint8_t>& excluded, uint8_t value, std::vector<uint8_t>& labels) {
  if (excluded.empty()) return false;
  if (excluded.size() != labels.size()) throw Error("mark_excluded: mask and labels differ in size");
  bool any = false;
  for (size_t i = 0; i < labels.size(); ++i)
    if (excluded[i]) labels[i] = value, any = true;
  return any;
}

std::vector<MaskInstance> modelled_instances(const SemanticFrame& frame, const SemanticParams& params,
                                             const float* depth_m, size_t min_pixels) {
  std::map<uint16_t, size_t> index;  // id -> position in out
  std::vector<MaskInstance> out;
  for (const auto& [id, name] : frame.classes)
    if (id != 0 && is_modelled_class(params, name)) {
      index[id] = out.size();
      out.push_back({id, name, {}});
    }
  if (out.empty()) return out;
  std::vector<int32_t> slot(0x10000, -1);
  for (const auto& [id, k] : index) slot[id] = int32_t(k);
  for (size_t i = 0; i < frame.ids.size(); ++i)
    if (const int32_t k = slot[frame.ids[i]]; k >= 0 && depth_m[i] > 0.0f) out[size_t(k)].pixels.push_back(i);
  std::erase_if(out, [&](const MaskInstance& m) { return m.pixels.size() < std::max<size_t>(min_pixels, 1); });
  return out;
}

double iou(const std::vector<size_t>& pixels, const std::vector<uint8_t>& labels, uint8_t label, size_t label_pixels) {
  size_t both = 0;
  for (size_t i : pixels) both += labels[i] == label;
  const size_t either = pixels.size() + label_pixels - both;
  return either > 0 ? double(both) / double(either) : 0.0;
}

std::vector<InstanceCandidates::Seen> InstanceCandidates::update(
    const std::vector<const MaskInstance*>& uncovered, const std::vector<std::optional<Eigen::Vector3d>>& centroids,
    size_t image_pixels) {
  std::vector<Seen> counts(uncovered.size());
  const bool have_previous = previous_.size() == image_pixels;
  for (size_t k = 0; k < uncovered.size(); ++k) {
    if (!have_previous) break;
    std::vector<size_t> overlap(previous_count_.size() + 1, 0);
    for (size_t i : uncovered[k]->pixels) ++overlap[previous_[i]];
    size_t best = 0;
    for (size_t c = 1; c < overlap.size(); ++c)
      if (overlap[c] > (best > 0 ? overlap[best] : 0)) best = c;
    if (best > 0 && 2 * overlap[best] >= std::min(uncovered[k]->pixels.size(), previous_size_[best - 1]))
      counts[k] = {previous_count_[best - 1] + 1, previous_centroid_[best - 1]};
  }
  previous_.assign(image_pixels, 0);
  previous_count_.clear();
  previous_size_.clear();
  previous_centroid_.clear();
  for (size_t k = 0; k < uncovered.size() && k < 0xFFFE; ++k) {
    previous_count_.push_back(counts[k].frames);
    previous_centroid_.push_back(k < centroids.size() ? centroids[k] : std::nullopt);
    previous_size_.push_back(uncovered[k]->pixels.size());
    for (size_t i : uncovered[k]->pixels) previous_[i] = static_cast<uint16_t>(k + 1);
  }
  return counts;
}

std::optional<std::pair<std::string, double>> ClassVotes::best() const {
  int total = 0;
  const std::pair<const std::string, int>* top = nullptr;
  for (const auto& entry : votes_) {
    total += entry.second;
    if (!top || entry.second > top->second) top = &entry;
  }
  if (!top || total <= 0) return std::nullopt;
  return std::pair{top->first, double(top->second) / double(total)};
}

}  // namespace cofusion::slam
