// The model lifecycle of CoFusion (see docs/design.md, "Frame timeline"): from the frame's
// segmentation to model slots; rigidity trials, merges, spawns, re-activation and retirement;
// instance masks; movers.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "segmentation/connected_components.h"
#include "slam/co_fusion.h"
#include "slam/co_fusion_model.h"

namespace cofusion::slam {
using namespace internal;  // the label slots (co_fusion_model.h)

bool relative_pose_held(const PoseHistory& a, const PoseHistory& b, const Eigen::Isometry3d& T_a_b,
                        double max_translation_m, double max_rotation_deg) {
  auto ia = a.begin();
  for (const auto& [frame, T_world_b] : b) {
    while (ia != a.end() && ia->first < frame) ++ia;
    if (ia == a.end()) break;
    if (ia->first != frame) continue;
    const Eigen::Isometry3d change = (ia->second.inverse() * T_world_b).inverse() * T_a_b;
    if (change.translation().norm() > max_translation_m || rotation_deg(change) > max_rotation_deg) return false;
  }
  return true;
}

namespace {
// Pixels per slot (kNoSlot is none): integer counts per block of pixels in parallel, then added.
// One serial pass stalls on its own increments (most pixels share a few slots).
std::vector<int> slot_pixel_counts(const std::vector<uint8_t>& slots) {
  constexpr size_t kBlock = 16384;
  const size_t blocks = (slots.size() + kBlock - 1) / kBlock;
  std::vector<std::array<int, kSlots>> block_counts(blocks, std::array<int, kSlots>{});
  tbb::parallel_for(size_t{0}, blocks, [&](size_t b) {
    std::array<int, kSlots>& c = block_counts[b];
    for (size_t i = b * kBlock; i < std::min(slots.size(), (b + 1) * kBlock); ++i)
      if (slots[i] < kSlots) ++c[slots[i]];
  });
  std::vector<int> counts(kSlots, 0);
  for (const auto& c : block_counts)
    for (int s = 0; s < kSlots; ++s) counts[size_t(s)] += c[size_t(s)];
  return counts;
}
}  // namespace

// Turns the segmentation (labels = index into `order`, order.size() = outlier) into model slots
// and applies the lifecycle rules: rigidity trials, merges, spawns and re-activations, absence
// and retirement. Uploads the final label map.
std::vector<uint8_t> CoFusion::apply_lifecycle(const segmentation::SegmentationResult& seg,
                                               const std::vector<std::vector<float>>& costs, const float* depth_m,
                                               const uint8_t* rgb, std::vector<Model*>& order, CoFusionFrame& out,
                                               std::vector<int>& spawned_slots) {
  auto lap = std::chrono::steady_clock::now();
  const auto part = [&](const char* name) {
    const auto now = std::chrono::steady_clock::now();
    out.lifecycle_parts_ms.emplace_back(name, std::chrono::duration<double, std::milli>(now - lap).count());
    lap = now;
  };
  std::vector<uint8_t> slots = slots_from_segmentation(seg, costs, depth_m, order, out);
  part("slots");
  merge_static_newcomers(order, depth_m, rgb, slots, out);
  merge_comoving(order, slots, out);
  part("merges");
  SpawnPlan plan = plan_spawns(seg, depth_m, static_cast<uint8_t>(order.size()), *order.front(), slots, out);
  part("spawn plan");
  // Pixels per slot, kept up to date as the new regions take their (free) slots; an object model
  // whose slot has none lost its object in this segmentation.
  std::vector<int> slot_pixels = slot_pixel_counts(slots);
  uint32_t taken = 0;  // slots given to this frame's new models
  for (SpawnPlan::Spawn& sp : plan.spawns) {
    sp.slot = free_slot(taken);
    taken |= 1u << sp.slot;
    for (size_t i : plan.regions[sp.region]) {
      if (slots[i] != kNoSlot) --slot_pixels[slots[i]];
      slots[i] = static_cast<uint8_t>(sp.slot);
      ++slot_pixels[size_t(sp.slot)];
    }
  }
  hold_candidates(plan, order.front()->slot, slots, slot_pixels);
  part("slot counts");
  // Resting models exist only where instances spawn models (semantic/both modes).
  if (params_.semantic.mode != SegmentationMode::kMotion)
    scene_unexplained_share_ = scene_unexplained_share(costs.front(), slots, params_.costs.max_explained_cost_m);
  if (semantic_) apply_instances(slots, slot_pixels, taken, depth_m, costs.front(), out, spawned_slots);
  wake_resting(costs.front(), slots, out, spawned_slots);
  part("instances, resting");
  upload_labels(slots);
  part("label upload");
  for (const SpawnPlan::Spawn& sp : plan.spawns)
    spawn_or_reactivate(sp, plan.regions[sp.region], depth_m, rgb, slot_pixels, out, spawned_slots);
  update_presence(slot_pixels, out);
  part("spawns, presence");
  std::erase_if(models_, [](const std::unique_ptr<Model>& m) { return m->slot == kRemovedSlot; });
  return slots;
}

// Each pixel's slot: its model's where the segmentation gave it to a model whose motion explains
// it (the background's where an object has no geometry there and the background explains it:
// MotionCostParams::background_takes_unmodelled), unclaimed where it is an outlier or unlabelled
// with depth, else none. Then the young models
// that fail their rigidity trial are dropped (drop_nonrigid).
std::vector<uint8_t> CoFusion::slots_from_segmentation(const segmentation::SegmentationResult& seg,
                                                       const std::vector<std::vector<float>>& costs,
                                                       const float* depth_m, const std::vector<Model*>& order,
                                                       CoFusionFrame& out) {
  const size_t n = size_t(intrinsics_.width) * intrinsics_.height;
  const uint8_t outlier = static_cast<uint8_t>(order.size());
  std::vector<uint8_t> slots(n, kNoSlot);
  unexplained_slots_.resize(n);
  const float max_cost = params_.costs.max_explained_cost_m;
  const bool takes_unmodelled = params_.costs.background_takes_unmodelled;
  // Per model: pixels the segmentation gave it, and of those the ones its motion explains (counts
  // per block of rows in parallel, then added).
  constexpr size_t kRows = 32;
  const size_t width = size_t(intrinsics_.width), blocks = (size_t(intrinsics_.height) + kRows - 1) / kRows;
  std::vector<int> block_counts(blocks * 2 * order.size(), 0);
  tbb::parallel_for(size_t{0}, blocks, [&](size_t b) {
    int* labelled = block_counts.data() + b * 2 * order.size();
    int* explained = labelled + order.size();
    for (size_t i = b * kRows * width; i < std::min(n, (b + 1) * kRows * width); ++i) {
      uint8_t l = seg.labels[i];
      if (l > 0 && l < outlier && takes_unmodelled && !order[l]->resting && std::isnan(costs[l][i]) &&
          depth_m[i] > 0.0f && costs[0][i] <= max_cost)
        l = 0;  // MotionCostParams::background_takes_unmodelled (order[0] is the background)
      if (l < outlier) ++labelled[l];
      unexplained_slots_[i] = kNoSlot;
      if (l < outlier && !(costs[l][i] > max_cost)) {
        slots[i] = static_cast<uint8_t>(order[l]->slot);
        ++explained[l];
      } else if (l < outlier) {
        unexplained_slots_[i] = static_cast<uint8_t>(order[l]->slot);
      } else if (l == outlier || (l == segmentation::kNoLabel && depth_m[i] > 0.0f)) {
        slots[i] = kUnclaimedSlot;
      }
    }
  });
  std::vector<int> labelled(order.size(), 0), explained(order.size(), 0);
  for (size_t b = 0; b < blocks; ++b)
    for (size_t k = 0; k < order.size(); ++k) {
      labelled[k] += block_counts[b * 2 * order.size() + k];
      explained[k] += block_counts[b * 2 * order.size() + order.size() + k];
    }
  drop_nonrigid(order, seg.labels, labelled, explained, slots, out);
  return slots;
}

// Also in unexplained_slots_, so that the reported labels follow a merge (the freed slot may be
// taken by a new model in the same frame).
void CoFusion::relabel(std::vector<uint8_t>& slots, int from, int to) {
  for (std::vector<uint8_t>* v : {&slots, &unexplained_slots_})
    for (auto& s : *v)
      if (s == from) s = static_cast<uint8_t>(to);
}

// A young model that has not moved relative to the background within its probation, or whose
// motion never showed in its pixels (LifecycleParams::probation_observed), is no object: it is
// merged back, its pixels given to the background.
void CoFusion::merge_static_newcomers(const std::vector<Model*>& order, const float* depth_m, const uint8_t* rgb,
                                      std::vector<uint8_t>& slots, CoFusionFrame& out) {
  const LifecycleParams& p = params_.lifecycle;
  Model& bg = *order.front();
  for (Model* m : order) {
    if (m->id == 0 || m->state != ModelState::kActive || !m->on_probation) continue;
    const Eigen::Isometry3d moved = m->trajectory.front().second.inverse() * m->surfels.T_world_model;
    const double travel_m =
        m->probation_start_world ? (m->surfels.T_world_model.translation() - *m->probation_start_world).norm() : 0.0;
    const bool far_enough = std::max(moved.translation().norm(), travel_m) >= p.static_translation_m ||
                            rotation_deg(moved) >= p.static_rotation_deg;
    const bool observed = far_enough && motion_observed(*m, slots, depth_m, rgb);
    if (observed) {
      m->on_probation = false;
      m->probation_evidence = {};
    } else if (frame_ - m->first_frame >= p.probation_frames) {
      relabel(slots, m->slot, bg.slot);
      merge_into(bg, *m, out, far_enough ? "its motion did not show in its pixels" : "did not move relative to the background");
    }
  }
}

// Whether the model's motion since its spawn shows in this frame (observed_motion.h); true for
// models without spawn evidence (not spawned by motion, or the test is off).
bool CoFusion::motion_observed(const Model& m, const std::vector<uint8_t>& slots, const float* depth_m,
                               const uint8_t* rgb) const {
  if (m.probation_evidence.points.empty()) return true;
  std::vector<size_t> pixels;
  for (size_t i = 0; i < slots.size(); ++i)
    if (slots[i] == m.slot) pixels.push_back(i);
  const Eigen::Isometry3d motion_world = m.surfels.T_world_model * m.trajectory.front().second.inverse();
  return slam::motion_observed(m.probation_evidence, pixels, motion_world, depth_m, rgb, intrinsics_, T_world_camera_,
                               params_.lifecycle.probation_observed);
}

// Two object models that moved (both of them) as one body over the last merge_window_frames, and
// never moved apart in the frames both were active, become one.
void CoFusion::merge_comoving(const std::vector<Model*>& order, std::vector<uint8_t>& slots, CoFusionFrame& out) {
  const LifecycleParams& p = params_.lifecycle;
  const int window = p.merge_window_frames;
  const auto pose_at = [](const Model& m, size_t back) { return m.trajectory[m.trajectory.size() - 1 - back].second; };
  const auto moved = [&](const Eigen::Isometry3d& T) {
    return T.translation().norm() >= p.static_translation_m || rotation_deg(T) >= p.static_rotation_deg;
  };
  for (Model* a : order) {
    for (Model* b : order) {
      if (a->id == 0 || b->id <= a->id || a->state != ModelState::kActive || b->state != ModelState::kActive) continue;
      if (a->on_probation || b->on_probation) continue;
      if (int(a->trajectory.size()) <= window || int(b->trajectory.size()) <= window) continue;
      const Eigen::Isometry3d rel_now = a->surfels.T_world_model.inverse() * b->surfels.T_world_model;
      const Eigen::Isometry3d rel_then = pose_at(*a, window - 1).inverse() * pose_at(*b, window - 1);
      const Eigen::Isometry3d change = rel_then.inverse() * rel_now;
      const Eigen::Isometry3d a_moved = pose_at(*a, window - 1).inverse() * a->surfels.T_world_model;
      const Eigen::Isometry3d b_moved = pose_at(*b, window - 1).inverse() * b->surfels.T_world_model;
      if (change.translation().norm() < p.merge_translation_m && rotation_deg(change) < p.merge_rotation_deg &&
          moved(a_moved) && moved(b_moved) &&
          relative_pose_held(a->trajectory, b->trajectory, rel_now, p.merge_history_translation_m,
                             p.merge_history_rotation_deg)) {
        relabel(slots, b->slot, a->slot);
        merge_into(*a, *b, out, "moves with model " + std::to_string(a->id));
      }
    }
  }
}

// The pixels of every connected outlier region (4-connectivity) that is no mover and covers
// between candidate_min_area_fraction() and
// spawn_max_area_fraction of the image, largest first; `rects` gets their bounding rectangles.
std::vector<std::vector<size_t>> CoFusion::outlier_regions(const segmentation::SegmentationResult& seg, uint8_t outlier,
                                                           std::vector<uint8_t>& slots, std::vector<PixelRect>& rects) {
  const LifecycleParams& p = params_.lifecycle;
  const int width = intrinsics_.width, height = intrinsics_.height;
  const double n = double(width) * height;
  segmentation::label_components(seg.labels.data(), width, height, std::optional<uint8_t>{}, components_);
  // Per component: whether it spawns nothing (a mover; below, also changed pixels alone).
  std::vector<char> mover = mark_movers(outlier, slots);
  if (!rising_.empty() || !changed_.empty()) {
    // Rising and changed background pixels (rising_background, changed_since_previous) join the
    // outlier regions; mover pixels leave them (the same regions as mover flags give without them).
    std::vector<uint8_t> labels = seg.labels;
    for (size_t i = 0; i < labels.size(); ++i)
      if (slots[i] == kMoverSlot) labels[i] = segmentation::kNoLabel;
      else if ((!rising_.empty() && rising_[i]) || (!changed_.empty() && changed_[i])) labels[i] = outlier;
    segmentation::label_components(labels.data(), width, height, std::optional<uint8_t>{}, components_);
    mover.assign(components_.components.size(), 0);
    // Changed pixels alone make no region: they only extend an outlier or a rising region.
    std::vector<char> seeded(components_.components.size(), 0);
    for (const auto& run : components_.runs)
      for (int x = run.x0; x < run.x1 && !seeded[size_t(run.component)]; ++x) {
        const size_t i = size_t(run.y) * size_t(width) + size_t(x);
        seeded[size_t(run.component)] = seg.labels[i] == outlier || (!rising_.empty() && rising_[i]);
      }
    for (size_t c = 0; c < mover.size(); ++c) mover[c] = !seeded[c];
  }
  const double min_fraction = candidate_min_area_fraction();
  std::vector<int> large_components;
  for (int c = 0; c < int(components_.components.size()); ++c) {
    const auto& info = components_.components[size_t(c)];
    if (info.value == outlier && !mover[size_t(c)] && double(info.pixels) > min_fraction * n &&
        double(info.pixels) <= p.spawn_max_area_fraction * n)
      large_components.push_back(c);
  }
  std::sort(large_components.begin(), large_components.end(), [&](int x, int y) {
    return components_.components[size_t(x)].pixels > components_.components[size_t(y)].pixels;
  });
  std::vector<int> region_of(components_.components.size(), -1);
  rects.clear();
  for (size_t r = 0; r < large_components.size(); ++r) {
    region_of[size_t(large_components[r])] = int(r);
    const auto& info = components_.components[size_t(large_components[r])];
    rects.push_back({info.x0, info.y0, info.x1, info.y1});
  }
  std::vector<std::vector<size_t>> regions(large_components.size());
  for (const auto& run : components_.runs)
    if (run.component >= 0 && region_of[size_t(run.component)] >= 0)
      for (int x = run.x0; x < run.x1; ++x)
        regions[size_t(region_of[size_t(run.component)])].push_back(size_t(run.y) * size_t(width) + size_t(x));
  return regions;
}

namespace {
// Per pixel 1 where its superpixel's mean cost (over the pixels with a cost) is at least
// min_cost_m and the segmentation gave it to the background (0) or the outlier label, else 0.
std::vector<uint8_t> raised_superpixels(const segmentation::Superpixels& superpixels, const std::vector<float>& cost_m,
                                        const std::vector<uint8_t>& labels, uint8_t outlier, double min_cost_m) {
  const size_t n = cost_m.size();
  std::vector<double> sum(size_t(superpixels.count), 0.0);
  std::vector<int> count(size_t(superpixels.count), 0);
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(cost_m[i])) continue;
    sum[size_t(superpixels.label[i])] += cost_m[i];
    ++count[size_t(superpixels.label[i])];
  }
  std::vector<uint8_t> raised(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const size_t s = size_t(superpixels.label[i]);
    raised[i] = (labels[i] == 0 || labels[i] == outlier) && count[s] > 0 && sum[s] >= min_cost_m * count[s];
  }
  return raised;
}
}  // namespace

// LifecycleParams::rising_*: per pixel 1 where the background's cost rises as over an object that
// starts to move slowly, else 0; empty when there is no such pixel. `labels`: the segmentation's
// (0 = the background). Moves the history of the background's costs on by this frame.
std::vector<uint8_t> CoFusion::rising_background(const segmentation::Superpixels& superpixels,
                                                 const std::vector<float>& background_costs,
                                                 const std::vector<uint8_t>& labels, uint8_t outlier) {
  const LifecycleParams& p = params_.lifecycle;
  const auto& h = background_cost_history_;
  const bool history = p.rising_min_step_m > 0 && h.size() == 2 && h[0].first == frame_ - 2 &&
                       h[1].first == frame_ - 1 && superpixels.label.size() == background_costs.size();
  std::vector<uint8_t> rising;
  if (history && spawn_camera_steady(*models_.front()))
    rising = rising_regions(raised_superpixels(superpixels, background_costs, labels, outlier, p.rising_min_cost_m),
                            {&h[0].second, &h[1].second, &background_costs}, labels);
  if (p.rising_min_step_m > 0) {  // the history, reusing the oldest frame's storage
    std::vector<float> costs;
    if (background_cost_history_.size() == 2) {
      costs = std::move(background_cost_history_.front().second);
      background_cost_history_.pop_front();
    }
    costs.assign(background_costs.begin(), background_costs.end());
    background_cost_history_.emplace_back(frame_, std::move(costs));
  }
  return rising;
}

// The background pixels (label 0) of the regions of `raised` whose mean cost rises, with a cost of
// their own of at least rising_min_cost_m (rising_background); empty when there is none. `costs`:
// the background's costs two frames ago, one frame ago and now.
std::vector<uint8_t> CoFusion::rising_regions(const std::vector<uint8_t>& raised,
                                              const std::array<const std::vector<float>*, 3>& costs,
                                              const std::vector<uint8_t>& labels) {
  const LifecycleParams& p = params_.lifecycle;
  const std::vector<float>& now = *costs[2];
  const size_t n = now.size(), width = size_t(intrinsics_.width);
  segmentation::label_components(raised.data(), intrinsics_.width, intrinsics_.height, std::optional<uint8_t>{0},
                                 rising_components_);
  const double min_pixels = p.rising_min_area_fraction * double(n);
  // Per component: the three frames' cost sums over its pixels with a cost in all three; their count.
  std::vector<std::array<double, 4>> sums(rising_components_.components.size(), {0, 0, 0, 0});
  for (const auto& run : rising_components_.runs) {
    if (double(rising_components_.components[size_t(run.component)].pixels) < min_pixels) continue;
    auto& m = sums[size_t(run.component)];
    for (size_t i = size_t(run.y) * width + size_t(run.x0); i < size_t(run.y) * width + size_t(run.x1); ++i)
      if (std::isfinite((*costs[0])[i]) && std::isfinite((*costs[1])[i]) && std::isfinite(now[i]))
        m[0] += (*costs[0])[i], m[1] += (*costs[1])[i], m[2] += now[i], m[3] += 1;
  }
  std::vector<uint8_t> rising;
  for (const auto& run : rising_components_.runs) {
    const auto& m = sums[size_t(run.component)];
    const double step = p.rising_min_step_m * m[3];
    if (m[3] < 0.5 * min_pixels || m[2] > p.rising_max_cost_m * m[3] || m[2] - m[1] < step || m[1] - m[0] < step)
      continue;
    if (rising.empty()) rising.assign(n, 0);
    for (size_t i = size_t(run.y) * width + size_t(run.x0); i < size_t(run.y) * width + size_t(run.x1); ++i)
      rising[i] = labels[i] == 0 && now[i] >= p.rising_min_cost_m;
  }
  return rising;
}

bool CoFusion::can_sample_previous() const {
  const size_t n = size_t(intrinsics_.width) * size_t(intrinsics_.height);
  return params_.motion_segmentation && params_.lifecycle.slide_min_shift_px > 0 && previous_intensity_.size() == n &&
         previous_depth_m_.size() == n && !camera_history_.empty() && camera_history_.back();
}

// The previous frame's grey level (bilinear) and gradient (the larger central difference, per
// pixel) where the camera's motion puts each pixel of this frame, if the previous frame saw a
// surface at that depth there (else -1). Needs only the camera's motion, not the segmentation.
CoFusion::PreviousSamples CoFusion::sample_previous(const float* depth_m, const Eigen::Isometry3d& T_previous_current_d) const {
  const int w = intrinsics_.width, h = intrinsics_.height;
  const Eigen::Isometry3f T_previous_current = T_previous_current_d.cast<float>();
  const float* prev = previous_intensity_.data();
  PreviousSamples s;
  s.intensity.assign(size_t(w) * size_t(h), -1.0f);
  s.gradient.assign(s.intensity.size(), 0.0f);
  tbb::parallel_for(tbb::blocked_range<int>(1, h - 1, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        const size_t i = size_t(y) * size_t(w) + size_t(x);
        const float z = depth_m[i];
        if (!(z > 0.0f)) continue;
        const Eigen::Vector3f p_current((float(x) - float(intrinsics_.cx)) / float(intrinsics_.fx) * z,
                                        (float(y) - float(intrinsics_.cy)) / float(intrinsics_.fy) * z, z);
        const Eigen::Vector3f q = T_previous_current * p_current;
        if (!(q.z() > 0.0f)) continue;
        const float u = float(intrinsics_.fx) * q.x() / q.z() + float(intrinsics_.cx);
        const float v = float(intrinsics_.fy) * q.y() / q.z() + float(intrinsics_.cy);
        if (!(u >= 1.0f && v >= 1.0f && u < float(w - 2) && v < float(h - 2))) continue;
        const size_t j = size_t(int(v)) * size_t(w) + size_t(int(u));
        const float z_previous = previous_depth_m_[j];
        if (!(z_previous > 0.0f) || std::abs(z_previous - q.z()) > 0.02f * q.z() + 0.01f) continue;
        const float a = u - std::floor(u), b = v - std::floor(v);
        const size_t row = size_t(w);
        s.intensity[i] = (1 - a) * (1 - b) * prev[j] + a * (1 - b) * prev[j + 1] + (1 - a) * b * prev[j + row] +
                         a * b * prev[j + row + 1];
        s.gradient[i] = 0.5f * std::max(std::abs(prev[j + 1] - prev[j - 1]), std::abs(prev[j + row] - prev[j - row]));
      }
  });
  return s;
}

// The frames' exposure ratio (previous / current) over the background pixels (label 0) sampled.
float CoFusion::exposure_gain(const PreviousSamples& s, const uint8_t* rgb, const std::vector<uint8_t>& labels) const {
  const int w = intrinsics_.width, h = intrinsics_.height;
  std::vector<double> sum_previous(size_t(h), 0.0), sum_current(size_t(h), 0.0);  // per row: deterministic
  tbb::parallel_for(tbb::blocked_range<int>(1, h - 1, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (size_t i = size_t(y) * size_t(w); i < size_t(y + 1) * size_t(w); ++i)
        if (labels[i] == 0 && s.intensity[i] >= 0.0f) {
          sum_previous[size_t(y)] += s.intensity[i];
          sum_current[size_t(y)] += grey_level(rgb, i);
        }
  });
  double previous = 0, current = 0;
  for (int y = 0; y < h; ++y) previous += sum_previous[size_t(y)], current += sum_current[size_t(y)];
  return current > 0 ? float(previous / current) : 1.0f;
}

// LifecycleParams::slide_*: per pixel 1 for the background pixels of superpixels whose image
// changed since the previous frame more than the camera's motion explains, else 0; empty when
// there is none (or no previous frame, or the camera is not steady enough for a spawn).
// The samples are previous_samples_ where they were taken while the GPU computed the residuals
// (CoFusion::overlap_host_work_), else taken here.
std::vector<uint8_t> CoFusion::changed_since_previous(const segmentation::Superpixels& superpixels,
                                                      const float* depth_m, const uint8_t* rgb,
                                                      const std::vector<uint8_t>& labels) const {
  const LifecycleParams& p = params_.lifecycle;
  const size_t n = labels.size();
  std::vector<uint8_t> changed;
  if (superpixels.label.size() != n || !spawn_camera_steady(*models_.front())) return changed;
  std::optional<PreviousSamples> taken_now;
  if (!previous_samples_ && can_sample_previous())
    taken_now = sample_previous(depth_m, camera_history_.back()->inverse() * T_world_camera_);
  const PreviousSamples* samples = previous_samples_ ? &*previous_samples_ : taken_now ? &*taken_now : nullptr;
  if (!samples || samples->intensity.size() != n) return changed;
  const PreviousSamples& s = *samples;
  const float gain = exposure_gain(s, rgb, labels);
  // Per superpixel, its background pixels tested and those that differ (integer counts, in
  // parallel); then its background pixels where enough differ.
  const size_t count = size_t(superpixels.count);
  std::vector<std::atomic<int>> tested(count), differ(count);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      if (labels[i] != 0 || s.intensity[i] < 0.0f) continue;
      const float d = std::abs(gain * grey_level(rgb, i) - s.intensity[i]);
      const size_t sp = size_t(superpixels.label[i]);
      tested[sp].fetch_add(1, std::memory_order_relaxed);
      if (d > p.slide_min_intensity && d > float(p.slide_min_shift_px) * s.gradient[i])
        differ[sp].fetch_add(1, std::memory_order_relaxed);
    }
  });
  std::vector<uint8_t> changes(count, 0);
  bool any = false;
  for (size_t sp = 0; sp < count; ++sp) {
    changes[sp] = tested[sp] > 0 && double(differ[sp]) >= p.slide_min_fraction * double(tested[sp]);
    any = any || changes[sp];
  }
  if (!any) return changed;
  changed.assign(n, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) changed[i] = labels[i] == 0 && changes[size_t(superpixels.label[i])];
  });
  return changed;
}

// Centroid (camera frame) of a region's live points: a new model's origin, and with the previous
// frame's candidate it overlaps most the region's motion over the last frame. None without depth.
std::optional<Eigen::Vector3d> CoFusion::region_centroid(const std::vector<size_t>& pixels, const float* depth_m) const {
  const int width = intrinsics_.width;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  size_t count = 0;
  for (size_t i : pixels) {
    const float d = depth_m[i];
    if (!(d > 0.0f)) continue;
    const double x = double(i % width), y = double(i / width);
    sum += Eigen::Vector3d((x - intrinsics_.cx) / intrinsics_.fx * d, (y - intrinsics_.cy) / intrinsics_.fy * d, d);
    ++count;
  }
  if (count == 0) return std::nullopt;
  return sum / double(count);
}

// Which outlier regions spawn a model: one that was a spawn-sized candidate in the previous frame
// (transient outliers, a blurred frame or a depth glitch, spawn nothing), while the camera is
// steady, within the active-model limit, and that moved as one rigid body since the previous frame
// (LifecycleParams::spawn_rigidity; a person entering the view does not). The others are this
// frame's candidates for the next. Several objects starting to move at once each spawn.
CoFusion::SpawnPlan CoFusion::plan_spawns(const segmentation::SegmentationResult& seg, const float* depth_m,
                                          uint8_t outlier, const Model& bg, std::vector<uint8_t>& slots,
                                          CoFusionFrame& out) {
  const LifecycleParams& p = params_.lifecycle;
  const size_t n = slots.size();
  SpawnPlan plan;
  plan.regions = outlier_regions(seg, outlier, slots, plan.region_rects);
  int active_count = 0;
  for (auto& m : models_) active_count += m->state == ModelState::kActive;
  const bool camera_steady = spawn_camera_steady(bg);
  const std::vector<uint8_t> previous_candidates = std::move(spawn_candidate_);
  const std::vector<SpawnCandidate> previous = std::move(spawn_candidates_);
  spawn_candidate_.assign(n, 0);
  spawn_candidates_.clear();
  // Semantic mode: models come from instance masks only.
  if (params_.semantic.mode == SegmentationMode::kSemantic) plan.regions.clear();
  for (size_t r = 0; r < plan.regions.size(); ++r) {
    const std::vector<size_t>& pixels = plan.regions[r];
    const std::optional<Eigen::Vector3d> centroid = region_centroid(pixels, depth_m);
    // Which previous candidate the region overlaps most gives its last position.
    std::vector<size_t> overlap(previous.size() + 1, 0);
    if (previous_candidates.size() == n)
      for (size_t i : pixels) ++overlap[previous_candidates[i]];
    // Hysteresis (spawn_keep_area_fraction): only spawn-sized candidates confirm a region; any
    // candidate continues one (spawn_persist_*).
    size_t confirmed = 0, continuing = 0, best_previous = 0;
    for (size_t k = 1; k < overlap.size(); ++k) {
      if (previous[k - 1].large) confirmed += overlap[k];
      continuing += overlap[k];
      if (overlap[k] > overlap[best_previous]) best_previous = k;
    }
    const double min_overlap = p.spawn_min_overlap * double(pixels.size());
    CandidateTrack track;
    if (camera_steady) {
      const bool continues = double(continuing) >= min_overlap && best_previous > 0;
      const std::optional<Eigen::Vector3d> world =
          centroid ? std::optional<Eigen::Vector3d>(T_world_camera_ * *centroid) : std::nullopt;
      track = (continues ? previous[best_previous - 1].track : CandidateTrack{}).continued(world);
    }
    const bool large = double(pixels.size()) > p.spawn_min_area_fraction * double(n);
    const bool at_keep_size = double(pixels.size()) > keep_area_fraction() * double(n);
    const bool confirmed_large = double(confirmed) >= min_overlap && at_keep_size;
    const bool travelled = !confirmed_large && persisted_and_moved(track, plan.region_rects[r]);
    const bool persistent = confirmed_large || travelled;
    const std::optional<Eigen::Vector3d> previous_centroid =
        best_previous > 0 ? previous[best_previous - 1].centroid : std::nullopt;
    // A region under the keep size beside an excluded mover (a person) is taken for a part of it
    // that the mask missed.
    const bool beside_mover = !at_keep_size && persistent && near_mover(pixels, slots, p.spawn_persist_mover_clearance_px);
    const bool eligible = frame_ >= p.warmup_frames && camera_steady && persistent && !beside_mover &&
                          active_count + int(plan.spawns.size()) < p.max_active_models;
    const std::optional<double> rigid =
        eligible ? rigid_fraction(pixels, depth_m, centroid, previous_centroid) : std::nullopt;
    if (eligible && (!rigid || *rigid >= p.spawn_rigidity.min_aligned_fraction)) {
      plan.spawns.push_back({r, -1, centroid, previous_centroid, rigid, travelled ? track.first_world : std::nullopt});
      continue;
    }
    if (eligible) {  // it failed the rigidity check
      char what[160];
      std::snprintf(what, sizeof what, "a region of %.1f%% of the image spawned nothing: %.0f%% of it moved rigidly",
                    100.0 * double(pixels.size()) / double(n), 100.0 * *rigid);
      out.events.push_back("frame " + std::to_string(frame_) + ": " + what);
    }
    // Only candidates of spawn_keep_area_fraction are held: a smaller one the background never
    // fused again would stay an outlier region, and a candidate, for as long as it is in view.
    if (p.hold_spawn_candidates && at_keep_size) plan.held.push_back(r);
    if (spawn_candidates_.size() < 254) {  // a candidate for the next frame
      spawn_candidates_.push_back({centroid, large, track});
      for (size_t i : pixels) spawn_candidate_[i] = static_cast<uint8_t>(spawn_candidates_.size());
    }
  }
  return plan;
}

bool CoFusion::near_mover(const std::vector<size_t>& pixels, const std::vector<uint8_t>& slots, int reach_px) const {
  return within_reach_of_slot(pixels, slots, intrinsics_.width, intrinsics_.height, kMoverSlot, reach_px);
}

bool internal::within_reach_of_slot(const std::vector<size_t>& pixels, const std::vector<uint8_t>& slots, int width,
                                    int height, uint8_t slot, int reach_px) {
  for (size_t i : pixels) {
    const int x = int(i % size_t(width)), y = int(i / size_t(width));
    for (int d = 1; d <= reach_px; ++d) {
      if ((x - d >= 0 && slots[i - size_t(d)] == slot) || (x + d < width && slots[i + size_t(d)] == slot) ||
          (y - d >= 0 && slots[i - size_t(d) * size_t(width)] == slot) ||
          (y + d < height && slots[i + size_t(d) * size_t(width)] == slot))
        return true;
    }
  }
  return false;
}

double CoFusion::keep_area_fraction() const {
  const LifecycleParams& p = params_.lifecycle;
  return p.spawn_keep_area_fraction > 0 ? p.spawn_keep_area_fraction : p.spawn_min_area_fraction;
}

double CoFusion::candidate_min_area_fraction() const {
  const LifecycleParams& p = params_.lifecycle;
  if (p.spawn_persist_frames <= 0 || p.spawn_persist_min_area_fraction <= 0) return keep_area_fraction();
  return std::min(keep_area_fraction(), p.spawn_persist_min_area_fraction);
}

CoFusion::CandidateTrack CoFusion::CandidateTrack::continued(const std::optional<Eigen::Vector3d>& world_centroid) const {
  CandidateTrack t = *this;
  ++t.frames;
  if (!world_centroid) return t;
  if (!t.first_world) t.first_world = world_centroid;
  if (t.last_world) t.path_m += (*world_centroid - *t.last_world).norm();
  t.last_world = world_centroid;
  return t;
}

// LifecycleParams::spawn_persist_*: whether a candidate region (this frame's bounding rectangle)
// has persisted and moved on long enough to spawn below the paper's size.
bool CoFusion::persisted_and_moved(const CandidateTrack& track, const PixelRect& rect) const {
  const LifecycleParams& p = params_.lifecycle;
  if (p.spawn_persist_frames <= 0 || track.frames < p.spawn_persist_frames || !track.first_world || !track.last_world)
    return false;
  if (rect.near_border(intrinsics_.width, intrinsics_.height, p.coast_border_px)) return false;
  const double travel_m = (*track.last_world - *track.first_world).norm();
  const double distance_m = (*track.last_world - T_world_camera_.translation()).norm();
  return travel_m >= p.spawn_persist_min_travel_rel * distance_m &&
         travel_m >= p.spawn_persist_min_straightness * track.path_m;
}

// LifecycleParams::hold_spawn_candidates: the background's pixels in the held candidate regions
// belong to no model this frame (kNoSlot).
void CoFusion::hold_candidates(const SpawnPlan& plan, int background_slot, std::vector<uint8_t>& slots,
                               std::vector<int>& slot_pixels) {
  for (size_t r : plan.held)
    for (size_t i : plan.regions[r])
      if (slots[i] == background_slot) {
        slots[i] = kNoSlot;
        --slot_pixels[size_t(background_slot)];
      }
}

// Whether the camera (the background's tracking, bg) is steady enough for a spawn this frame.
bool CoFusion::spawn_camera_steady(const Model& bg) const {
  return !bg.tracking.failed && !bg.motion_refused && steady_motion(bg.motion) && camera_was_steady() &&
         frame_ - last_recovery_frame_ >= params_.relocalisation.settle_frames;
}

// LifecycleParams::spawn_max_camera_*: whether a camera motion (T_previous_current) is slow enough
// for spawning.
bool CoFusion::steady_motion(const Eigen::Isometry3d& motion) const {
  const LifecycleParams& p = params_.lifecycle;
  return motion.translation().norm() <= p.spawn_max_camera_translation_m &&
         rotation_deg(motion) <= p.spawn_max_camera_rotation_deg;
}

// LifecycleParams::spawn_steady_frames: whether the camera moved steadily over the
// spawn_steady_frames - 1 frames before this one (camera_history_ holds their poses): none of them
// lost, and their per-frame rotations and translations summed within that many frames' limits. A
// fast turn exceeds the sum; a single frame the tracking got off and took back (a moving object
// that drags the camera for a frame before it is segmented) does not.
bool CoFusion::camera_was_steady() const {
  const LifecycleParams& p = params_.lifecycle;
  const size_t motions = size_t(std::max(p.spawn_steady_frames - 1, 0));
  if (motions == 0) return true;
  if (camera_history_.size() < motions + 1) return false;
  double rotation_sum_deg = 0, translation_sum_m = 0;
  for (size_t k = camera_history_.size() - motions; k < camera_history_.size(); ++k) {
    const auto& before = camera_history_[k - 1];
    const auto& after = camera_history_[k];
    if (!before || !after) return false;
    const Eigen::Isometry3d motion = before->inverse() * *after;
    rotation_sum_deg += rotation_deg(motion);
    translation_sum_m += motion.translation().norm();
  }
  return rotation_sum_deg <= double(motions) * p.spawn_max_camera_rotation_deg &&
         translation_sum_m <= double(motions) * p.spawn_max_camera_translation_m;
}

// LifecycleParams::spawn_rigidity: the fraction of the region that moved as one rigid body since
// the previous frame, from the camera's motion and the region's centroid step (when the region was
// a candidate there too and the step is plausible, spawn_max_velocity_guess_m); nullopt when the
// check is off or the previous frame's depth or pose is unknown.
std::optional<double> CoFusion::rigid_fraction(const std::vector<size_t>& pixels, const float* depth_m,
                                               const std::optional<Eigen::Vector3d>& centroid,
                                               const std::optional<Eigen::Vector3d>& previous_centroid) const {
  const LifecycleParams& p = params_.lifecycle;
  const size_t n = size_t(intrinsics_.width) * intrinsics_.height;
  if (!p.spawn_rigidity.enabled || p.spawn_rigidity.min_aligned_fraction <= 0 || previous_depth_m_.size() != n ||
      camera_history_.empty() || !camera_history_.back())
    return std::nullopt;
  Eigen::Isometry3d T_previous_current = camera_history_.back()->inverse() * T_world_camera_;
  if (centroid && previous_centroid) {
    const Eigen::Vector3d step = *previous_centroid - T_previous_current * *centroid;
    if (step.norm() <= p.spawn_max_velocity_guess_m) T_previous_current.pretranslate(step);
  }
  return region_rigidity(depth_m, previous_depth_m_.data(), intrinsics_, pixels, T_previous_current, p.spawn_rigidity)
      .aligned_fraction();
}

// A spawning region first re-finds an object model that lost every pixel this frame (its tracking
// slipped off the object, which now shows up as an outlier region), then re-activates an inactive
// model that aligns with it; else it becomes a new model.
void CoFusion::spawn_or_reactivate(const SpawnPlan::Spawn& sp, const std::vector<size_t>& pixels,
                                   const float* depth_m, const uint8_t* rgb, const std::vector<int>& slot_pixels,
                                   CoFusionFrame& out, std::vector<int>& spawned_slots) {
  const LifecycleParams& p = params_.lifecycle;
  const size_t n = size_t(intrinsics_.width) * intrinsics_.height;
  const Eigen::Vector3d centroid = sp.centroid.value_or(Eigen::Vector3d::Zero());
  char share[32];
  std::snprintf(share, sizeof share, "%.1f%%", 100.0 * double(pixels.size()) / double(n));
  // A new or re-activated model has no velocity yet; the region's centroid moved by `step` over
  // the last frame, which is the first tracking's guess (an object entering fast, 3 cm per frame,
  // moves out of the pixels its model is masked to, and from a zero guess the model stays put).
  Eigen::Isometry3d velocity_guess = Eigen::Isometry3d::Identity();
  if (sp.centroid && sp.previous_centroid) {
    const Eigen::Vector3d step = *sp.centroid - *sp.previous_centroid;
    if (step.norm() <= p.spawn_max_velocity_guess_m) velocity_guess = Eigen::Translation3d(-step) * Eigen::Isometry3d::Identity();
  }
  const auto lost = [&](const Model& m) { return m.slot >= 0 && slot_pixels[size_t(m.slot)] == 0; };
  Model* reactivated = nullptr;
  bool was_active = false, was_resting = false;
  if (p.reactivate)
    for (const ModelState state : {ModelState::kActive, ModelState::kInactive}) {
      for (auto& m : models_) {
        // A model merged away this frame is inactive until the list is pruned: not a candidate.
        if (m->state != state || m->id == 0 || m->slot == kRemovedSlot || (state == ModelState::kActive && !lost(*m))) continue;
        const bool resting = m->resting;
        if (try_reactivate(*m, sp.slot, centroid)) {
          reactivated = m.get();
          was_active = state == ModelState::kActive;
          was_resting = resting;
          break;
        }
      }
      if (reactivated) break;
    }
  if (reactivated) {
    reactivated->last_motion = velocity_guess;
    reactivated->guess_from_centroid_step = true;
    const std::string id = std::to_string(reactivated->id);
    // A resting model whose pixels became an outlier region has started moving, as wake_resting
    // finds it when its pixels stay its own: its surfels leave the background.
    if (was_resting) {
      spawned_slots.push_back(sp.slot);
      out.events.push_back("frame " + std::to_string(frame_) + ": model " + id + " started moving (re-found as " +
                           share + " of the image)");
      return;
    }
    out.events.push_back("frame " + std::to_string(frame_) + ": " + (was_active ? "re-found model " : "re-activated model ") +
                         id + " (" + share + " of the image)");
    return;
  }
  Eigen::Isometry3d T_camera_model = Eigen::Isometry3d::Identity();
  T_camera_model.translation() = centroid;
  Model& m = create_model(sp.slot, T_world_camera_ * T_camera_model);
  m.probation_start_world = sp.track_start_world;
  m.probation_evidence = record_spawn(pixels, depth_m, rgb, intrinsics_, T_world_camera_, p.probation_observed);
  m.pixels = static_cast<int>(pixels.size());
  m.last_motion = velocity_guess;
  m.guess_from_centroid_step = true;
  spawned_slots.push_back(sp.slot);
  char rigid[48] = "";
  if (sp.rigid_fraction) std::snprintf(rigid, sizeof rigid, ", %.0f%% of it moved rigidly", 100.0 * *sp.rigid_fraction);
  out.events.push_back("frame " + std::to_string(frame_) + ": spawned model " + std::to_string(m.id) + " (" + share +
                       " of the image" + rigid + ")");
}

// Pixel counts, where each object was last seen well, absence and retirement.
void CoFusion::update_presence(const std::vector<int>& slot_pixels, CoFusionFrame& out) {
  const LifecycleParams& p = params_.lifecycle;
  const double n = double(intrinsics_.width) * intrinsics_.height;
  unclaimed_fraction_ = double(slot_pixels[kUnclaimedSlot]) / n;
  for (auto& m : models_) {
    if (m->state != ModelState::kActive) continue;
    m->pixels = slot_pixels[size_t(m->slot)];
    if (m->id != 0 && m->tracked && !m->tracking.failed && double(m->pixels) >= p.spawn_min_area_fraction * n)
      m->T_world_model_last_seen = m->surfels.T_world_model;
    if (m->pixels > 0) {
      m->last_frame = frame_;
      m->unseen_frames = 0;
    } else if (m->id != 0 && ++m->unseen_frames >= p.deactivate_after_frames) {
      retire(*m, out);
    }
  }
}

namespace {
// Gives `pixels` to `slot`, keeping the per-slot pixel counts.
void assign_pixels(const std::vector<size_t>& pixels, int slot, std::vector<uint8_t>& slots, std::vector<int>& slot_pixels) {
  for (size_t i : pixels) {
    if (slots[i] != kNoSlot) --slot_pixels[slots[i]];
    slots[i] = static_cast<uint8_t>(slot);
    ++slot_pixels[size_t(slot)];
  }
}
}  // namespace

// Instance masks (SemanticParams): an instance of a modelled class votes for the object model whose
// footprint (its labelled pixels in the previous frame or in this segmentation) it overlaps with
// IoU >= join_min_iou; in semantic/both modes its pixels then join that model. In those modes an
// instance no model covers for confirm_frames consecutive frames spawns a model (spawn_instances).
void CoFusion::apply_instances(std::vector<uint8_t>& slots, std::vector<int>& slot_pixels, uint32_t& taken,
                               const float* depth_m, const std::vector<float>& background_costs, CoFusionFrame& out,
                               std::vector<int>& spawned_slots) {
  const SemanticParams& sp = params_.semantic;
  const size_t n = slots.size();
  const bool modelling = sp.mode != SegmentationMode::kMotion;
  const std::vector<MaskInstance> instances =
      modelled_instances(*semantic_, sp, depth_m, size_t(sp.min_instance_area_fraction * double(n)));
  std::vector<int> previous_pixels(kSlots, 0);
  if (slots_.size() == n)
    for (uint8_t s : slots_)
      if (s < kSlots) ++previous_pixels[s];
  const uint32_t pending = taken;  // slots of this frame's motion spawns
  std::vector<const MaskInstance*> uncovered;
  for (const MaskInstance& inst : instances) {
    Model* best = nullptr;
    double best_iou = 0;
    for (auto& m : models_) {
      if (m->id == 0 || m->state != ModelState::kActive || m->slot < 0) continue;
      const auto slot = static_cast<uint8_t>(m->slot);
      double v = iou(inst.pixels, slots, slot, size_t(slot_pixels[slot]));
      if (slots_.size() == n) v = std::max(v, iou(inst.pixels, slots_, slot, size_t(previous_pixels[slot])));
      if (v > best_iou) best_iou = v, best = m.get();
    }
    // A region that spawns a model from motion this frame (both mode) covers it too.
    bool spawning = false;
    for (int s = 0; s < kSlots && !spawning; ++s)
      spawning = (pending & (1u << s)) && iou(inst.pixels, slots, uint8_t(s), size_t(slot_pixels[size_t(s)])) >= sp.join_min_iou;
    if (spawning) continue;
    if (best && best_iou >= sp.join_min_iou) {
      best->class_votes.add(inst.class_name);
      if (modelling) assign_pixels(inst.pixels, best->slot, slots, slot_pixels);
    } else {
      uncovered.push_back(&inst);
    }
  }
  if (modelling) spawn_instances(uncovered, slots, slot_pixels, taken, depth_m, background_costs, out, spawned_slots);
}

// The instances no model covers (apply_instances): each one seen in confirm_frames consecutive
// frames (repeated masks are no new sighting: SemanticFrame::repeated) re-activates an inactive
// model of its class there (reactivate_at_instance) or spawns a model with no probation (it need not move), resting where the background explains it
// (SemanticParams::resting_max_unexplained_fraction); else its surfels leave the older models as a
// motion spawn's do, and its first tracking starts from its centroid's step over the last frame.
void CoFusion::spawn_instances(const std::vector<const MaskInstance*>& uncovered, std::vector<uint8_t>& slots,
                               std::vector<int>& slot_pixels, uint32_t& taken, const float* depth_m,
                               const std::vector<float>& background_costs, CoFusionFrame& out,
                               std::vector<int>& spawned_slots) {
  const SemanticParams& sp = params_.semantic;
  const size_t n = slots.size();
  if (semantic_->repeated) return;  // a detection carried on is no new sighting
  std::vector<std::optional<Eigen::Vector3d>> centroids;  // camera frame; instances have pixels with depth
  for (const MaskInstance* inst : uncovered) centroids.push_back(region_centroid(inst->pixels, depth_m));
  const std::vector<InstanceCandidates::Seen> seen = instance_candidates_.update(uncovered, centroids, n);
  for (size_t k = 0; k < uncovered.size(); ++k) {
    if (seen[k].frames < sp.confirm_frames || int(live_models().size()) >= params_.lifecycle.max_active_models) continue;
    const int slot = free_slot(taken);
    if (slot < 0) break;
    taken |= 1u << slot;
    assign_pixels(uncovered[k]->pixels, slot, slots, slot_pixels);
    if (reactivate_at_instance(*uncovered[k], T_world_camera_ * *centroids[k], slot, out)) continue;
    Eigen::Isometry3d T_camera_model = Eigen::Isometry3d::Identity();
    T_camera_model.translation() = *centroids[k];
    Model& m = create_model(slot, T_world_camera_ * T_camera_model);
    m.on_probation = false;
    const std::optional<double> unexplained =
        background_unexplained_share(background_costs, uncovered[k]->pixels, params_.costs.max_explained_cost_m);
    m.resting = !unexplained || *unexplained - scene_unexplained_share_ <= sp.resting_max_unexplained_fraction;
    if (!m.resting && seen[k].previous_centroid) {
      const Eigen::Vector3d step = *centroids[k] - *seen[k].previous_centroid;
      if (step.norm() <= params_.lifecycle.spawn_max_velocity_guess_m) {
        m.last_motion = Eigen::Translation3d(-step) * Eigen::Isometry3d::Identity();
        m.guess_from_centroid_step = true;
      }
    }
    m.pixels = int(uncovered[k]->pixels.size());
    m.class_votes.add(uncovered[k]->class_name);
    // A resting model's surfels stay in the background too; a moving one's are removed from it.
    if (!m.resting) spawned_slots.push_back(slot);
    char share[32];
    std::snprintf(share, sizeof share, "%.1f%%", 100.0 * double(uncovered[k]->pixels.size()) / double(n));
    out.events.push_back("frame " + std::to_string(frame_) + ": spawned model " + std::to_string(m.id) + " from a " +
                         uncovered[k]->class_name + " instance seen in " + std::to_string(seen[k].frames) + " frames (" + share +
                         " of the image" + (m.resting ? ", resting)" : ")"));
  }
}

// An instance that no active model covers may be an inactive model of its class come back into
// view (a chair the camera turned away from): the model whose surfels' bounding sphere holds the
// instance's centroid (world frame) is re-activated, resting, in `slot` (no tracking: a resting
// model keeps its world pose, and it wakes if it moved meanwhile). Returns whether one was.
bool CoFusion::reactivate_at_instance(const MaskInstance& instance, const Eigen::Vector3d& centroid_world, int slot,
                                      CoFusionFrame& out) {
  Model* found = nullptr;
  double nearest_m = 0;
  for (auto& m : models_) {
    if (m->state != ModelState::kInactive || m->slot != kInactiveSlot || !m->extent) continue;
    const auto best = m->class_votes.best();
    if (!best || best->first != instance.class_name) continue;
    const double d = (m->surfels.T_world_model * m->extent->centre_model - centroid_world).norm();
    if (d <= m->extent->radius_m && (!found || d < nearest_m)) found = m.get(), nearest_m = d;
  }
  if (!found) return false;
  found->state = ModelState::kActive;
  found->slot = slot;
  found->resting = true;
  found->tracked = false;
  found->unseen_frames = 0;
  found->last_frame = frame_;
  found->last_motion = Eigen::Isometry3d::Identity();
  found->pixels = int(instance.pixels.size());
  found->class_votes.add(instance.class_name);
  out.events.push_back("frame " + std::to_string(frame_) + ": re-activated model " + std::to_string(found->id) +
                       " at a " + instance.class_name + " instance (resting)");
  return true;
}

// Of `pixels`, the share whose background cost is above max_cost_m, among those the background's
// prediction covers (cost not NaN); nullopt when it covers fewer than half of them (no evidence).
namespace {
// Background costs counted: those its prediction covers (not NaN), and of them those above max_cost_m.
struct UnexplainedCount {
  size_t covered = 0, unexplained = 0;
  void add(float cost_m, float max_cost_m) {
    if (std::isnan(cost_m)) return;
    ++covered;
    unexplained += cost_m > max_cost_m;
  }
  double share() const { return covered == 0 ? 0.0 : double(unexplained) / double(covered); }
};
}  // namespace

std::optional<double> internal::background_unexplained_share(const std::vector<float>& background_costs,
                                                             const std::vector<size_t>& pixels, float max_cost_m) {
  UnexplainedCount count;
  for (size_t i : pixels) count.add(background_costs[i], max_cost_m);
  if (count.covered == 0 || 2 * count.covered < pixels.size()) return std::nullopt;
  return count.share();
}

// Of the pixels with a model or an outlier label (not movers'), the share whose background cost is
// above max_cost_m among those the background's prediction covers; 0 when it covers none.
double internal::scene_unexplained_share(const std::vector<float>& background_costs, const std::vector<uint8_t>& slots,
                                         float max_cost_m) {
  UnexplainedCount count;
  for (size_t i = 0; i < slots.size(); ++i)
    if (slots[i] != kNoSlot && slots[i] != kMoverSlot) count.add(background_costs[i], max_cost_m);
  return count.share();
}

// SemanticParams::resting_max_unexplained_fraction: a resting model whose pixels the background no
// longer explains, well beyond how much of the rest of the view it leaves unexplained (a fast turn
// blurs and misaligns the whole prediction), has moved. From now on it is tracked on its own, and
// the background drops its surfels on its pixels (as for a new model: it joins `spawned_slots`).
void CoFusion::wake_resting(const std::vector<float>& background_costs, const std::vector<uint8_t>& slots,
                            CoFusionFrame& out, std::vector<int>& spawned_slots) {
  std::vector<std::vector<size_t>> pixels(kSlots);
  bool any = false;
  for (const auto& m : models_) any = any || (m->resting && m->slot >= 0);
  if (!any) return;
  for (size_t i = 0; i < slots.size(); ++i)
    if (slots[i] < kSlots) pixels[slots[i]].push_back(i);
  for (const auto& m : models_) {
    if (!m->resting || m->slot < 0 || m->state != ModelState::kActive) continue;
    const std::optional<double> unexplained =
        background_unexplained_share(background_costs, pixels[size_t(m->slot)], params_.costs.max_explained_cost_m);
    if (!unexplained || *unexplained - scene_unexplained_share_ <= params_.semantic.resting_max_unexplained_fraction) continue;
    m->resting = false;
    spawned_slots.push_back(m->slot);
    out.events.push_back("frame " + std::to_string(frame_) + ": model " + std::to_string(m->id) +
                         " started moving (the background explains " +
                         std::to_string(int(std::lround(100 * (1 - *unexplained)))) + "% of its pixels)");
  }
}

// Non-rigid movers (LifecycleParams::rigidity_trial_frames): a young object model whose motion
// leaves too much of its own label unexplained in too many frames of its trial is dropped; its
// label's pixels become mover pixels.
void CoFusion::drop_nonrigid(const std::vector<Model*>& order, const std::vector<uint8_t>& seg_labels,
                             const std::vector<int>& labelled, const std::vector<int>& explained,
                             std::vector<uint8_t>& slots, CoFusionFrame& out) {
  const LifecycleParams& p = params_.lifecycle;
  for (size_t k = 1; k < order.size(); ++k) {
    Model& m = *order[k];
    const double fraction = labelled[k] > 0 ? double(explained[k]) / double(labelled[k]) : 0.0;
    if (m.state != ModelState::kActive || !m.tracked || m.resting || frame_ - m.first_frame > p.rigidity_trial_frames) continue;
    if (!m.tracking.failed && fraction >= p.rigid_min_explained_fraction) continue;
    if (++m.rigidity_failures < p.rigidity_max_failures) continue;
    for (size_t i = 0; i < slots.size(); ++i)
      if (size_t(seg_labels[i]) == k || slots[i] == m.slot) slots[i] = kMoverSlot;
    m.state = ModelState::kInactive;
    m.slot = kRemovedSlot;
    char why[96];
    std::snprintf(why, sizeof why, "its motion explained %.0f%% of its pixels", 100.0 * fraction);
    out.events.push_back("frame " + std::to_string(frame_) + ": dropped model " + std::to_string(m.id) +
                         " (not rigid: " + (m.tracking.failed ? std::string("tracking failed") : std::string(why)) +
                         " in " + std::to_string(m.rigidity_failures) + " frames of its first " +
                         std::to_string(frame_ - m.first_frame) + ")");
  }
}

// Mover regions (LifecycleParams::mover_min_overlap): the outlier components of this frame's
// segmentation (components_) that overlap the previous frame's mover pixels enough; their pixels
// become mover pixels. Returns per component whether it is a mover.
std::vector<char> CoFusion::mark_movers(uint8_t outlier, std::vector<uint8_t>& slots) const {
  const size_t width = size_t(intrinsics_.width);
  std::vector<char> mover(components_.components.size(), 0);
  if (slots_.size() != slots.size()) return mover;
  std::vector<int64_t> overlap(mover.size(), 0);
  for (const auto& run : components_.runs)
    if (run.component >= 0 && run.value == outlier)
      for (int x = run.x0; x < run.x1; ++x) overlap[size_t(run.component)] += slots_[size_t(run.y) * width + size_t(x)] == kMoverSlot;
  for (size_t c = 0; c < mover.size(); ++c) {
    const auto& info = components_.components[c];
    mover[c] = info.value == outlier && overlap[c] > 0 &&
               double(overlap[c]) >= params_.lifecycle.mover_min_overlap * double(info.pixels);
  }
  for (const auto& run : components_.runs)
    if (run.component >= 0 && mover[size_t(run.component)])
      for (int x = run.x0; x < run.x1; ++x) slots[size_t(run.y) * width + size_t(x)] = kMoverSlot;
  return mover;
}

// Tries to align model m (inactive, or an object that lost every pixel this frame) with the
// region labelled `slot`, tracked with the region's pixels only, from two starts: its last
// orientation relative to the camera with its centre on the region's centroid, and where it was
// last seen (an object that left and comes back the same way, or the camera looking back at it).
// The start whose alignment has the most inliers wins if it passes the thresholds.
bool CoFusion::try_reactivate(Model& m, int slot, const Eigen::Vector3d& centroid_camera) {
  const std::vector<Surfel> surfels = m.surfels.download(m.stream);
  if (surfels.empty()) return false;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Surfel& s : surfels) centre += Eigen::Vector3d(s.px, s.py, s.pz);
  centre /= double(surfels.size());
  std::vector<Eigen::Isometry3d> starts;  // T_camera_model
  starts.push_back(T_world_camera_.inverse() * m.surfels.T_world_model);
  starts.back().translation() += centroid_camera - starts.back() * centre;
  if (m.T_world_model_last_seen) starts.push_back(T_world_camera_.inverse() * *m.T_world_model_last_seen);

  PredictionParams prediction;
  prediction.min_confidence = params_.slam.fusion.stable_confidence;
  const LifecycleParams& p = params_.lifecycle;
  std::optional<std::pair<TrackingResult, Eigen::Isometry3d>> best;
  for (const Eigen::Isometry3d& T_camera_model : starts) {
    m.stream.wait_next_on_gpu(labels_uploaded_);
    m.stream.run([&](gpu::CommandList& c) {
      surfels_.predict(c, m.surfels, T_camera_model, m.prediction, prediction, frame_);
      motion_.mask_levels(c, live_.levels, m.masked, labels_, 1u << slot);
    });
    const TrackingResult r = m.tracker.track(m.stream, m.masked, m.prediction.levels, Eigen::Isometry3d::Identity());
    if (r.failed || r.inlier_ratio < p.reactivate_min_inlier_ratio || r.icp_rms_m > p.reactivate_max_rms_m) continue;
    if (!best || r.inlier_ratio > best->first.inlier_ratio) best.emplace(r, T_camera_model);
  }
  if (!best) return false;
  const auto& [r, T_camera_model] = *best;
  m.surfels.T_world_model = T_world_camera_ * r.T_reference_live.inverse() * T_camera_model;
  m.state = ModelState::kActive;
  m.slot = slot;
  m.resting = false;  // found by its motion
  m.tracking = r;
  m.tracked = true;
  m.last_motion = Eigen::Isometry3d::Identity();
  m.unseen_frames = 0;
  m.last_frame = frame_;
  return true;
}

// Moves every surfel of `gone` into `keep` (expressed in keep's frame) and deletes `gone`.
void CoFusion::merge_into(Model& keep, Model& gone, CoFusionFrame& out, const std::string& why) {
  gone.stream.wait_idle();
  std::vector<Surfel> moved = gone.surfels.download(gone.stream);
  transform_surfels(moved, keep.surfels.T_world_model.inverse() * gone.surfels.T_world_model);
  std::vector<Surfel> all = keep.surfels.download(keep.stream);
  all.insert(all.end(), moved.begin(), moved.end());
  // Within keep's capacity limit (SurfelModel::make_room): the least confident go.
  const unsigned pixels = unsigned(intrinsics_.width) * unsigned(intrinsics_.height);
  const unsigned most = keep.surfels.limit(pixels, params_.slam.fusion.max_surfels);
  if (all.size() > most) {
    keep.culled += static_cast<unsigned>(all.size() - most);
    keep_most_confident(all, most);
  }
  keep.surfels.upload(keep.stream, all);
  keep.class_votes.merge(gone.class_votes);
  out.events.push_back("frame " + std::to_string(frame_) + ": merged model " + std::to_string(gone.id) + " into " +
                       std::to_string(keep.id) + " (" + why + ")");
  gone.state = ModelState::kInactive;
  gone.slot = kRemovedSlot;
}

void CoFusion::retire(Model& m, CoFusionFrame& out) {
  m.stream.wait_idle();
  const std::vector<Surfel> surfels = m.surfels.download(m.stream);
  const auto stable = static_cast<unsigned>(std::count_if(surfels.begin(), surfels.end(), [&](const Surfel& s) {
    return s.confidence >= params_.slam.fusion.stable_confidence;
  }));
  m.state = ModelState::kInactive;
  m.coasted_frames = 0;  // a re-activated model starts with its full allowance (lifecycle.coast_frames)
  const bool keep = stable >= params_.lifecycle.min_stable_surfels;
  if (keep) m.extent = surfel_extent(surfels);
  m.slot = keep ? kInactiveSlot : kRemovedSlot;
  out.events.push_back("frame " + std::to_string(frame_) + ": model " + std::to_string(m.id) + " left the view (" +
                       std::to_string(stable) + " stable surfels): " + (keep ? "inactive" : "deleted"));
}

}  // namespace cofusion::slam
