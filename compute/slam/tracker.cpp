#include "slam/tracker.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/error.h"
#include "embedded_shaders.h"
#include "shared/host_device.h"

namespace cofusion::slam {
namespace L = gpu_layout;

namespace {
TrackerParams validated(TrackerParams params) {
  validate(params, "Tracker");
  return params;
}

bool same_intrinsics(const Intrinsics& a, const Intrinsics& b) {
  auto close = [](double x, double y) { return std::abs(x - y) <= 1e-9 * std::max(1.0, std::abs(x)); };
  return a.width == b.width && a.height == b.height && close(a.fx, b.fx) && close(a.fy, b.fy) && close(a.cx, b.cx) &&
         close(a.cy, b.cy);
}

void require_buffer(const gpu::BufferPtr& buffer, size_t bytes, const std::string& what) {
  if (!buffer) throw Error(what + " is missing");
  if (buffer->size() < bytes)
    throw Error(what + " ('" + buffer->name() + "') holds " + std::to_string(buffer->size()) + " bytes, needs " +
                std::to_string(bytes));
}

// The reductions read every binding but the partial sums through its texel view.
uint32_t reduction_texel_bindings() { return ((1u << 10) - 1u) & ~(1u << ICP_RGB_BINDING_PARTIALS); }
}  // namespace

void check_levels(const std::vector<kernels::FramePyramid::Level>& live,
                  const std::vector<kernels::FramePyramid::Level>& reference, const std::string& what) {
  if (live.empty()) throw Error(what + ": the live frame has no pyramid levels");
  if (live.size() != reference.size())
    throw Error(what + ": live frame has " + std::to_string(live.size()) + " levels, reference " +
                std::to_string(reference.size()));
  for (size_t l = 0; l < live.size(); ++l) {
    const auto& a = live[l];
    const auto& b = reference[l];
    const std::string lv = what + ": level " + std::to_string(l);
    if (a.width < 1 || a.height < 1) throw Error(lv + ": empty image");
    if (a.width != b.width || a.height != b.height)
      throw Error(lv + ": live is " + std::to_string(a.width) + "x" + std::to_string(a.height) + ", reference " +
                  std::to_string(b.width) + "x" + std::to_string(b.height));
    if (a.intrinsics.width != a.width || a.intrinsics.height != a.height || !a.intrinsics.plausible())
      throw Error(lv + ": live intrinsics " + a.intrinsics.to_string() + " do not fit the image");
    if (!same_intrinsics(a.intrinsics, b.intrinsics))
      throw Error(lv + ": live intrinsics " + a.intrinsics.to_string() + " differ from reference " +
                  b.intrinsics.to_string());
    const size_t n = static_cast<size_t>(a.width) * static_cast<size_t>(a.height);
    require_buffer(a.vertex, n * 16, lv + " live vertex map");
    require_buffer(a.normal, n * 16, lv + " live normal map");
    require_buffer(a.intensity, n * 4, lv + " live intensity");
    require_buffer(b.vertex, n * 16, lv + " reference vertex map");
    require_buffer(b.normal, n * 16, lv + " reference normal map");
    require_buffer(b.intensity, n * 4, lv + " reference intensity");
    require_buffer(b.gradient, n * 8, lv + " reference gradient");
    require_buffer(a.gradient, n * 8, lv + " live gradient");
  }
}

Tracker::Tracker(gpu::Context& ctx, TrackerParams params)
    : ctx_(ctx),
      params_(validated(std::move(params))),
      reduce_(ctx, "icp_rgb_reduce", shaders::icp_rgb_reduce_comp(), 10, sizeof(L::IcpRgbReduceParams),
              reduction_texel_bindings()) {
  const auto& f = ctx.features();
  if (!f.subgroup_arithmetic)
    throw Error("Tracker: device '" + ctx.info().name + "' lacks subgroup arithmetic in compute shaders");
  if (f.subgroup_size * ICP_RGB_MAX_SUBGROUPS < ICP_RGB_GROUP_SIZE)
    throw Error("Tracker: device '" + ctx.info().name + "' has subgroups of " + std::to_string(f.subgroup_size) +
                " invocations; the reduction needs at least " +
                std::to_string(ICP_RGB_GROUP_SIZE / ICP_RGB_MAX_SUBGROUPS));
  set_params(params_);
}

void Tracker::set_params(const TrackerParams& requested) {
  validate(requested, "Tracker");
  TrackerParams params = requested;
  if (params.reduction_workgroups == 0)
    params.reduction_workgroups =
        ctx_.is_software() ? std::clamp(static_cast<int>(ctx_.software_threads()), 1, TrackerParams::kCpuReductionWorkgroups)
                           : TrackerParams::kGpuReductionWorkgroups;
  if (params.photometric_reweighted() && !reduce_reweighted_) {
    reduce_reweighted_.emplace(ctx_, "icp_rgb_reduce_reweighted", shaders::icp_rgb_reduce_reweighted_comp(), 11,
                               sizeof(L::IcpRgbReduceParams), reduction_texel_bindings());
    if (tile_weights_.empty()) tile_weights_.assign(ICP_RGB_TILES_X * ICP_RGB_TILES_Y, 1.0f);
    tile_weights_buffer_ = gpu::Buffer::create(ctx_, tile_weights_.size() * sizeof(float), "tracker tile weights");
    tile_weights_changed_ = true;
  }
  const size_t bytes = static_cast<size_t>(params.reduction_workgroups) * ICP_RGB_PARTIAL_STRIDE * sizeof(float);
  if (!partials_ || partials_->size() < bytes) partials_ = gpu::Buffer::create(ctx_, bytes, "tracker partial sums");
  params_ = params;
}

void Tracker::set_photometric_tile_weights(std::span<const float> weights) {
  if (weights.size() != size_t(ICP_RGB_TILES_X * ICP_RGB_TILES_Y))
    throw Error("Tracker: " + std::to_string(weights.size()) + " tile weights, needs " +
                std::to_string(ICP_RGB_TILES_X * ICP_RGB_TILES_Y));
  for (float w : weights)
    if (!(w >= 0 && std::isfinite(w))) throw Error("Tracker: a tile weight is negative or not finite");
  if (std::equal(weights.begin(), weights.end(), tile_weights_.begin(), tile_weights_.end())) return;
  tile_weights_.assign(weights.begin(), weights.end());
  tile_weights_changed_ = true;
}

uint32_t Tracker::record_reduction(gpu::CommandList& cmd, const kernels::FramePyramid::Level& live,
                                   const kernels::FramePyramid::Level& reference,
                                   const Eigen::Isometry3d& T_reference_live, const std::optional<PixelRect>& rect,
                                   const IterationScales& scales) {
  const Intrinsics& k = live.intrinsics;
  L::IcpRgbReduceParams p{};
  const Eigen::Matrix<double, 3, 4> T = T_reference_live.matrix().topRows<3>();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) p.T_reference_live[r * 4 + c] = static_cast<float>(T(r, c));
  p.fx = static_cast<float>(k.fx);
  p.fy = static_cast<float>(k.fy);
  p.cx = static_cast<float>(k.cx);
  p.cy = static_cast<float>(k.cy);
  p.width = static_cast<uint32_t>(live.width);
  p.height = static_cast<uint32_t>(live.height);
  p.max_distance_m = static_cast<float>(params_.max_correspondence_distance_m);
  p.min_normal_cos = static_cast<float>(std::cos(params_.max_normal_angle_deg * std::numbers::pi / 180.0));
  p.max_intensity_diff = static_cast<float>(params_.max_intensity_diff);
  p.rgb_huber_delta = static_cast<float>(scales.rgb);
  p.outline_rgb_delta = static_cast<float>(scales.rgb * params_.outline_huber_scale);
  p.icp_huber_delta_m = static_cast<float>(scales.icp_m);
  p.icp_noise_reference_depth_m = static_cast<float>(params_.icp_noise_reference_depth_m);
  p.gradient_weight_c = static_cast<float>(params_.photometric_gradient_c);
  p.flags = (params_.use_photometric ? ICP_RGB_FLAG_PHOTOMETRIC : 0u) | (params_.esm_gradient ? ICP_RGB_FLAG_ESM : 0u) |
            (params_.outline_photometric ? ICP_RGB_FLAG_OUTLINE : 0u) |
            (params_.photometric_cauchy_k > 0 ? ICP_RGB_FLAG_CAUCHY : 0u) |
            (params_.photometric_tile_weights ? ICP_RGB_FLAG_TILE_WEIGHTS : 0u) |
            (params_.photometric_skip_rim ? ICP_RGB_FLAG_SKIP_RIM : 0u);
  p.live_intensity_gain = static_cast<float>(scales.live_gain);
  p.outline_occlusion_margin_m = static_cast<float>(params_.outline_occlusion_margin_m);
  const PixelRect r = rect ? rect->clamped(live.width, live.height) : PixelRect::full(live.width, live.height);
  if (r.x0 > 0xFFFF || r.y0 > 0xFFFF) throw Error("Tracker: a tracking rectangle's origin beyond 65535 pixels");
  p.rect_x0y0 = static_cast<uint32_t>(r.x0) | static_cast<uint32_t>(r.y0) << 16;
  p.rect_width = static_cast<uint32_t>(r.width());
  p.rect_height = static_cast<uint32_t>(r.height());

  // Enough workgroups to give every invocation a pixel, at most reduction_workgroups.
  const uint32_t pixels = p.rect_width * p.rect_height;
  const uint32_t groups = std::clamp<uint32_t>(gpu::group_count(pixels, ICP_RGB_GROUP_SIZE), 1u,
                                               static_cast<uint32_t>(params_.reduction_workgroups));
  // The outline term's occlusion test reads the live depth; without the term any float map of the
  // level's size stands in (it is not read).
  if (params_.outline_photometric && !live.depth_m) throw Error("Tracker: the outline term needs the live level's depth");
  const gpu::BufferPtr& live_depth = live.depth_m ? live.depth_m : live.intensity;
  if (cmd.profiled()) cmd.set_profile_label(std::to_string(live.width) + "x" + std::to_string(live.height));
  if (!params_.photometric_reweighted()) {
    cmd.dispatch(reduce_,
                 {live.vertex, live.normal, live.intensity, reference.vertex, reference.normal, reference.intensity,
                  reference.gradient, partials_, live.gradient, live_depth},
                 p, groups);
    return groups;
  }
  if (tile_weights_changed_) {
    gpu::record_upload(ctx_, cmd, tile_weights_buffer_, tile_weights_.data(), tile_weights_.size() * sizeof(float), 0,
                       tile_weights_staging_);
    tile_weights_changed_ = false;
  }
  cmd.dispatch(*reduce_reweighted_,
               {live.vertex, live.normal, live.intensity, reference.vertex, reference.normal, reference.intensity,
                reference.gradient, partials_, live.gradient, live_depth, tile_weights_buffer_},
               p, groups);
  return groups;
}

const float* Tracker::record_readback(gpu::CommandList& cmd, uint32_t groups) {
  const size_t bytes = static_cast<size_t>(groups) * ICP_RGB_PARTIAL_STRIDE * sizeof(float);
  return static_cast<const float*>(gpu::record_download(ctx_, cmd, partials_, bytes, 0, partials_readback_));
}

LinearSystemSums Tracker::add_partials(const float* partials, uint32_t groups) {
  LinearSystemSums sums;
  for (uint32_t g = 0; g < groups; ++g) {
    const float* part = partials + static_cast<size_t>(g) * ICP_RGB_PARTIAL_STRIDE;
    for (int i = 0; i < ICP_RGB_TERM_VALUES; ++i) {
      sums.icp[i] += part[ICP_RGB_OFFSET_ICP + i];
      sums.rgb[i] += part[ICP_RGB_OFFSET_RGB + i];
    }
    sums.valid_live_pixels += part[ICP_RGB_OFFSET_VALID];
    sums.occluding_live_pixels += part[ICP_RGB_OFFSET_OCCLUDING];
    sums.reference_intensity_sum += part[ICP_RGB_OFFSET_REF_INTENSITY];
    sums.live_intensity_sum += part[ICP_RGB_OFFSET_LIVE_INTENSITY];
  }
  return sums;
}

LinearSystemSums Tracker::compute_sums(gpu::Stream& stream, const kernels::FramePyramid::Level& live,
                                       const kernels::FramePyramid::Level& reference,
                                       const Eigen::Isometry3d& T_reference_live,
                                       const std::optional<PixelRect>& rect, const IterationScales& scales) {
  auto cmd = stream.begin();
  const uint32_t groups = record_reduction(cmd, live, reference, T_reference_live, rect, scales);
  const float* partials = record_readback(cmd, groups);
  stream.wait(stream.submit(std::move(cmd)));
  return add_partials(partials, groups);
}

void Tracker::check_inputs(const std::vector<kernels::FramePyramid::Level>& live,
                           const std::vector<kernels::FramePyramid::Level>& reference,
                           const Eigen::Isometry3d& T_reference_live_guess, const std::string& what) const {
  check_levels(live, reference, what);
  if (live.size() > params_.iterations_per_level.size())
    throw Error(what + ": " + std::to_string(live.size()) + " pyramid levels but iterations_per_level has " +
                std::to_string(params_.iterations_per_level.size()) + " entries");
  if (!T_reference_live_guess.matrix().allFinite()) throw Error(what + ": the pose guess is not finite");
}

namespace {
std::vector<long> level_pixels(const std::vector<kernels::FramePyramid::Level>& levels) {
  std::vector<long> pixels;
  for (const auto& level : levels) pixels.push_back(static_cast<long>(level.width) * level.height);
  return pixels;
}

std::optional<PixelRect> rect_at(const std::optional<PixelRect>& rect_level0, const kernels::FramePyramid::Level& l,
                                 int level) {
  return rect_level0 ? std::optional(rect_level0->at_level(level, l.width, l.height)) : std::nullopt;
}
}  // namespace

TrackingResult Tracker::track(gpu::Stream& stream, const std::vector<kernels::FramePyramid::Level>& live,
                              const std::vector<kernels::FramePyramid::Level>& reference,
                              const Eigen::Isometry3d& T_reference_live_guess,
                              const std::optional<PixelRect>& rect_level0) {
  check_inputs(live, reference, T_reference_live_guess, "Tracker::track");
  return gauss_newton(
      level_pixels(live),
      [&](int level, const Eigen::Isometry3d& T, const IterationScales& scales) {
        const auto& l = live[size_t(level)];
        return compute_sums(stream, l, reference[size_t(level)], T, rect_at(rect_level0, l, level), scales);
      },
      T_reference_live_guess, params_);
}

void track_together(gpu::Stream& stream, std::span<TrackingJob> jobs, std::span<const gpu::TimelinePoint> waits) {
  std::vector<std::vector<long>> pixels;
  std::vector<TrackerParams> params;
  std::vector<GaussNewton> loops;
  pixels.reserve(jobs.size());  // the loops keep references to these
  params.reserve(jobs.size());
  loops.reserve(jobs.size());
  for (size_t j = 0; j < jobs.size(); ++j) {
    TrackingJob& job = jobs[j];
    if (!job.tracker || !job.live || !job.reference)
      throw Error("track_together: job " + std::to_string(j) + " is incomplete");
    for (size_t i = 0; i < j; ++i)
      if (jobs[i].tracker == job.tracker)
        throw Error("track_together: jobs " + std::to_string(i) + " and " + std::to_string(j) + " share a tracker");
    job.tracker->check_inputs(*job.live, *job.reference, job.T_reference_live_guess, "track_together");
    params.push_back(job.tracker->params());
    if (job.iterations_per_level) {
      const std::string what = "track_together: job " + std::to_string(j);
      params.back().iterations_per_level = *job.iterations_per_level;
      validate(params.back(), what);
      if (job.iterations_per_level->size() < job.live->size())
        throw Error(what + ": " + std::to_string(job.live->size()) + " pyramid levels but its iterations_per_level has " +
                    std::to_string(job.iterations_per_level->size()));
    }
    pixels.push_back(level_pixels(*job.live));
    loops.emplace_back(pixels.back(), job.T_reference_live_guess, params.back());
  }
  struct Pending {
    size_t job;
    uint32_t groups;
    const float* partials;
  };
  const auto unfinished = [&] {
    return std::any_of(loops.begin(), loops.end(), [](const GaussNewton& loop) { return !loop.done(); });
  };
  std::vector<Pending> pending;
  for (bool first = true; unfinished(); first = false) {
    auto cmd = stream.begin();
    pending.clear();
    for (size_t j = 0; j < jobs.size(); ++j) {
      const auto& request = loops[j].request();
      if (!request) continue;
      const TrackingJob& job = jobs[j];
      const auto& live = (*job.live)[size_t(request->level)];
      cmd.set_profile_group(job.profile_group);
      const uint32_t groups =
          job.tracker->record_reduction(cmd, live, (*job.reference)[size_t(request->level)], request->T_reference_live,
                                        rect_at(job.rect_level0, live, request->level), request->scales);
      pending.push_back({j, groups, nullptr});
    }
    for (Pending& p : pending) p.partials = jobs[p.job].tracker->record_readback(cmd, p.groups);
    stream.wait(stream.submit(std::move(cmd), first ? waits : std::span<const gpu::TimelinePoint>{}));
    for (const Pending& p : pending) loops[p.job].take(Tracker::add_partials(p.partials, p.groups));
  }
  for (size_t j = 0; j < jobs.size(); ++j) jobs[j].result = loops[j].result();
}

}  // namespace cofusion::slam
