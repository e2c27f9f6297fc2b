#include "slam/surfel_model.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "embedded_shaders.h"
#include "shared/host_device.h"

namespace cofusion::slam {
namespace L = gpu_layout;
using gpu::group_count;

void to_rows(const Eigen::Isometry3d& T, float out[12]) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out[r * 4 + c] = static_cast<float>(T.linear()(r, c));
    out[r * 4 + 3] = static_cast<float>(T.translation()(r));
  }
}

namespace {
uint32_t tiles(int n) { return group_count(static_cast<uint32_t>(n), COFUSION_TILE); }
}  // namespace

// ---------------------------------------------------------------------------------------------
SurfelModel::SurfelModel(gpu::Context& ctx, int id, unsigned initial_capacity) : ctx_(ctx), id_(id) {
  const uint64_t range = ctx.features().max_storage_buffer_range;
  max_capacity_ = static_cast<unsigned>(std::min<uint64_t>(range / sizeof(Surfel), 1u << 30));
  capacity_ = std::min(std::max(initial_capacity, 1024u), max_capacity_);
  const std::string name = "model " + std::to_string(id);
  surfels_ = gpu::Buffer::create(ctx, size_t{capacity_} * sizeof(Surfel), name + " surfels");
  scratch_ = gpu::Buffer::create(ctx, size_t{capacity_} * sizeof(Surfel), name + " surfels (compaction)");
  claim_ = gpu::Buffer::create(ctx, size_t{capacity_} * sizeof(uint32_t), name + " claims");
  merge_target_ = gpu::Buffer::create(ctx, size_t{capacity_} * sizeof(uint32_t), name + " merge targets");
  counter_ = gpu::Buffer::create(ctx, 4 * sizeof(uint32_t), name + " counter");
  maintenance_groups_ = gpu::Buffer::create(ctx, kernels::IndirectGroups::kBytes, name + " maintenance groups",
                                            gpu::BufferUsage::Indirect);
}

void SurfelModel::reserve(gpu::Stream& stream, unsigned needed) {
  if (needed <= capacity_) return;
  if (needed > max_capacity_)
    throw Error("model " + std::to_string(id_) + " needs room for " + std::to_string(needed) +
                " surfels; this device holds at most " + std::to_string(max_capacity_) +
                " per model (maxStorageBufferRange " + std::to_string(ctx_.features().max_storage_buffer_range) +
                " bytes)");
  unsigned capacity = capacity_;
  while (capacity < needed) capacity = static_cast<unsigned>(std::min<uint64_t>(uint64_t{capacity} * 2, max_capacity_));
  const std::string name = "model " + std::to_string(id_);
  // Every new buffer first, so that a failed allocation leaves the model as it was.
  auto surfels = gpu::Buffer::create(ctx_, size_t{capacity} * sizeof(Surfel), name + " surfels");
  auto scratch = gpu::Buffer::create(ctx_, size_t{capacity} * sizeof(Surfel), name + " surfels (compaction)");
  auto claim = gpu::Buffer::create(ctx_, size_t{capacity} * sizeof(uint32_t), name + " claims");
  auto merge_target = gpu::Buffer::create(ctx_, size_t{capacity} * sizeof(uint32_t), name + " merge targets");
  stream.run([&](gpu::CommandList& cmd) { cmd.copy(surfels_, surfels, size_t{count_} * sizeof(Surfel)); });
  surfels_ = std::move(surfels);
  scratch_ = std::move(scratch);
  claim_ = std::move(claim);
  merge_target_ = std::move(merge_target);
  capacity_ = capacity;
}

unsigned SurfelModel::limit(unsigned incoming, unsigned max_surfels) const {
  const unsigned device = max_capacity_ > incoming ? max_capacity_ - incoming : 0;
  return max_surfels > 0 ? std::min(max_surfels, device) : device;
}

namespace {
unsigned cull_target(unsigned limit, const FusionParams& params) {
  return static_cast<unsigned>(double(limit) * std::clamp(double(params.cull_keep_fraction), 0.0, 1.0));
}
}  // namespace

unsigned SurfelModel::make_room(gpu::Stream& stream, unsigned incoming, const FusionParams& params) {
  unsigned culled = 0;
  // At most two rounds: after a failed growth max_capacity_ is the present capacity, and the cull
  // leaves count_ + incoming within it, so reserve() allocates nothing.
  for (;;) {
    const unsigned most = limit(incoming, params.max_surfels);
    if (count_ > most) culled += cull_least_confident(stream, cull_target(most, params));
    try {
      reserve(stream, count_ + incoming);
      return culled;
    } catch (const gpu::DeviceMemoryError&) {
      if (max_capacity_ == capacity_) throw;
      max_capacity_ = capacity_;  // the device cannot grow this model further
    }
  }
}

unsigned SurfelModel::cull_least_confident(gpu::Stream& stream, unsigned keep) {
  if (count_ <= keep) return 0;
  std::vector<Surfel> surfels = download(stream);
  keep_most_confident(surfels, keep);
  if (!surfels.empty()) stream.upload(surfels_, surfels.data(), surfels.size() * sizeof(Surfel));
  const unsigned removed = count_ - keep;
  count_ = keep;
  culled_total_ += removed;
  return removed;
}

void keep_most_confident(std::vector<Surfel>& surfels, size_t keep) {
  if (surfels.size() <= keep) return;
  auto more_worth_keeping = [](const Surfel& a, const Surfel& b) {
    if (a.confidence != b.confidence) return a.confidence > b.confidence;
    if (a.last_seen_frame != b.last_seen_frame) return a.last_seen_frame > b.last_seen_frame;
    return a.created_frame > b.created_frame;
  };
  std::nth_element(surfels.begin(), surfels.begin() + std::ptrdiff_t(keep), surfels.end(), more_worth_keeping);
  surfels.resize(keep);
}

void SurfelModel::ensure_fusion_scratch(size_t pixels, size_t index_map_cells) {
  const std::string name = "model " + std::to_string(id_);
  if (!index_map_ || index_map_->size() < index_map_cells * 8)
    index_map_ = gpu::Buffer::create(ctx_, index_map_cells * 8, name + " fusion index map");
  if (!assoc_ || assoc_->size() < pixels * 4) assoc_ = gpu::Buffer::create(ctx_, pixels * 4, name + " fusion association");
  if (!no_labels_) no_labels_ = gpu::Buffer::create(ctx_, 4, name + " no labels");
}

const gpu::BufferPtr& SurfelModel::compaction_blocks(uint32_t elements) {
  const size_t bytes = kernels::CompactionScan::blocks_bytes(elements);
  if (!blocks_ || blocks_->size() < bytes)
    blocks_ = gpu::Buffer::create(ctx_, bytes, "model " + std::to_string(id_) + " compaction blocks");
  return blocks_;
}

const gpu::BufferPtr& SurfelModel::compaction_keep_mask(uint32_t elements) {
  const size_t bytes = kernels::CompactionScan::keep_mask_bytes(elements);
  if (!keep_mask_ || keep_mask_->size() < bytes)
    keep_mask_ = gpu::Buffer::create(ctx_, bytes, "model " + std::to_string(id_) + " compaction keep mask");
  return keep_mask_;
}

std::vector<Surfel> SurfelModel::download(gpu::Stream& stream) const {
  std::vector<Surfel> out(count_);
  stream.download(surfels_, out.data(), out.size() * sizeof(Surfel));
  return out;
}

void SurfelModel::upload(gpu::Stream& stream, const std::vector<Surfel>& surfels) {
  reserve(stream, static_cast<unsigned>(surfels.size()));
  stream.upload(surfels_, surfels.data(), surfels.size() * sizeof(Surfel));
  count_ = static_cast<unsigned>(surfels.size());
}

// ---------------------------------------------------------------------------------------------
ModelPrediction ModelPrediction::allocate(gpu::Context& ctx, const Intrinsics& intrinsics, int level_count,
                                          const std::string& name) {
  ModelPrediction p;
  for (int l = 0; l < level_count; ++l) {
    kernels::FramePyramid::Level level;
    level.intrinsics = intrinsics.at_level(l);
    level.width = level.intrinsics.width;
    level.height = level.intrinsics.height;
    const size_t n = size_t(level.width) * level.height;
    const std::string prefix = name + " L" + std::to_string(l) + " ";
    level.vertex = gpu::Buffer::create(ctx, n * 16, prefix + "vertex");
    level.normal = gpu::Buffer::create(ctx, n * 16, prefix + "normal");
    level.intensity = gpu::Buffer::create(ctx, n * 4, prefix + "intensity");
    level.gradient = gpu::Buffer::create(ctx, n * 8, prefix + "gradient");
    p.levels.push_back(std::move(level));
  }
  const size_t n0 = size_t(intrinsics.width) * intrinsics.height;
  p.depth_index = gpu::Buffer::create(ctx, n0 * 8, name + " depth/index");
  p.index_map = gpu::Buffer::create(ctx, n0 * 4, name + " index map");
  p.written = PixelRect::full(intrinsics.width, intrinsics.height);  // fresh buffers hold anything
  return p;
}

// ---------------------------------------------------------------------------------------------
SurfelPipelines::SurfelPipelines(gpu::Context& ctx, const kernels::Preprocessor& preprocessor)
    : preprocessor_(preprocessor),
      splat_(ctx, "splat_surfels", shaders::splat_surfels_comp(), 2, sizeof(L::SplatParams), 1u << SPLAT_BINDING_SURFELS),
      resolve_(ctx, "splat_resolve", shaders::splat_resolve_comp(), 6, sizeof(L::ResolveParams),
               (1u << RESOLVE_BINDING_SURFELS) | (1u << RESOLVE_BINDING_DEPTH_INDEX)),
      subsample_(ctx, "subsample_prediction", shaders::subsample_prediction_comp(), 6, sizeof(L::SubsampleParams),
                 (1u << SUBSAMPLE_BINDING_SRC_VERTEX) | (1u << SUBSAMPLE_BINDING_SRC_NORMAL) |
                     (1u << SUBSAMPLE_BINDING_SRC_INTENSITY)),
      scan_(ctx),
      groups_(ctx),
      associate_(ctx, "fuse_associate", shaders::fuse_associate_comp(), 9, sizeof(L::FuseParams),
                 (1u << FUSE_BINDING_SURFELS) | (1u << FUSE_BINDING_INDEX_MAP) | (1u << FUSE_BINDING_VERTEX) |
                     (1u << FUSE_BINDING_NORMAL) | (1u << FUSE_BINDING_LABELS)),
      count_new_(ctx, "fuse_count_new", shaders::fuse_count_new_comp(), 11, sizeof(L::FuseParams),
                 1u << FUSE_BINDING_ASSOC),
      update_(ctx, "fuse_update", shaders::fuse_update_comp(), 11, sizeof(L::FuseParams),
              (1u << FUSE_BINDING_SURFELS) | (1u << FUSE_BINDING_VERTEX) | (1u << FUSE_BINDING_NORMAL) |
                  (1u << FUSE_BINDING_RGB) | (1u << FUSE_BINDING_ASSOC) | (1u << FUSE_BINDING_CLAIM)),
      merge_select_(ctx, "surfel_merge_select", shaders::surfel_merge_select_comp(), 6, sizeof(L::MergeParams),
                    (1u << MERGE_BINDING_SURFELS) | (1u << MERGE_BINDING_INDEX_MAP) | (1u << MERGE_BINDING_LABELS)),
      merge_claim_(ctx, "surfel_merge_claim", shaders::surfel_merge_claim_comp(), 6, sizeof(L::MergeParams),
                   1u << MERGE_BINDING_TARGET),
      cleanup_(ctx, "surfel_cleanup", shaders::surfel_cleanup_comp(), 8, sizeof(L::CleanupParams),
               (1u << CLEANUP_BINDING_SRC) | (1u << CLEANUP_BINDING_DEPTH) | (1u << CLEANUP_BINDING_MERGE_TARGET) |
                   (1u << CLEANUP_BINDING_MERGE_CLAIM)),
      remove_region_(ctx, "surfel_remove_region", shaders::surfel_remove_region_comp(), 6,
                     sizeof(L::RemoveRegionParams),
                     (1u << REMOVE_REGION_BINDING_SRC) | (1u << REMOVE_REGION_BINDING_DEPTH) |
                         (1u << REMOVE_REGION_BINDING_LABELS)),
      compact_(ctx, "surfel_compact", shaders::surfel_compact_comp(), 4, 0, 1u << SURFEL_COMPACT_BINDING_SRC) {}

void SurfelPipelines::predict(gpu::CommandList& cmd, const SurfelModel& model, const Eigen::Isometry3d& T_camera_model,
                              ModelPrediction& out, const PredictionParams& params, int frame,
                              const std::optional<PixelRect>& rect) const {
  const auto& l0 = out.levels.at(0);
  const Intrinsics& k = l0.intrinsics;
  const PixelRect full = PixelRect::full(k.width, k.height);
  const PixelRect area = rect ? rect->clamped(k.width, k.height) : full;
  // Everything outside the last call's rectangle is empty already: clearing that rectangle and
  // rendering this one leaves everything outside this one empty.
  const PixelRect cover = area.united(out.written);
  L::SplatParams sp{};
  to_rows(T_camera_model, sp.T_camera_model);
  sp.fx = float(k.fx), sp.fy = float(k.fy), sp.cx = float(k.cx), sp.cy = float(k.cy);
  sp.width = uint32_t(k.width), sp.height = uint32_t(k.height);
  sp.surfel_count = model.count();
  sp.min_confidence = params.min_confidence;
  sp.frame = frame;
  sp.recent_window_frames = params.recent_window_frames;
  sp.grid_scale = 1;
  sp.footprint_px = uint32_t(params.footprint_px);
  sp.offset_penalty_rel = params.offset_penalty_rel;
  if (!area.empty()) {
    // The resolve reads only the area's keys; the splat may write anywhere.
    const size_t row_bytes = size_t(k.width) * 8;
    cmd.fill(out.depth_index, 0xFFFFFFFFu, size_t(area.y0) * row_bytes, size_t(area.height()) * row_bytes);
    cmd.barrier();
    cmd.set_profile_label("for prediction");
    splat(cmd, model.surfels(), out.depth_index, sp);
    cmd.set_profile_label("");
    cmd.barrier();
  }
  if (cover.empty()) return;
  L::ResolveParams rp{};
  std::copy(sp.T_camera_model, sp.T_camera_model + 12, rp.T_camera_model);
  rp.fx = sp.fx, rp.fy = sp.fy, rp.cx = sp.cx, rp.cy = sp.cy, rp.width = sp.width, rp.height = sp.height;
  rp.x0 = uint32_t(cover.x0), rp.y0 = uint32_t(cover.y0), rp.x1 = uint32_t(cover.x1), rp.y1 = uint32_t(cover.y1);
  rp.area_x0 = uint32_t(area.x0), rp.area_y0 = uint32_t(area.y0), rp.area_x1 = uint32_t(area.x1),
  rp.area_y1 = uint32_t(area.y1);
  resolve(cmd, model.surfels(), out.depth_index, l0, out.index_map, rp);
  cmd.barrier();
  // Level l pixel (x, y) copies level l-1 pixel (2x, 2y): outside the area's level-l rectangle
  // that pixel lies outside the area's level l-1 rectangle, so it is empty too.
  for (size_t l = 1; l < out.levels.size(); ++l) {
    subsample(cmd, out.levels[l - 1], out.levels[l], cover.at_level(int(l), out.levels[l].width, out.levels[l].height));
    cmd.barrier();
  }
  // One pixel beyond the covered intensities, as far as the 3x3 Sobel window reaches.
  for (size_t l = 0; l < out.levels.size(); ++l) {
    auto& level = out.levels[l];
    const PixelRect r = cover.at_level(int(l), level.width, level.height).grown(1).clamped(level.width, level.height);
    preprocessor_.intensity_gradient(cmd, level.intensity, level.gradient, level.width, level.height, r);
  }
  cmd.barrier();
  out.written = area;
}

void SurfelPipelines::splat(gpu::CommandList& cmd, const gpu::BufferPtr& surfels, const gpu::BufferPtr& grid,
                            const L::SplatParams& p) const {
  cmd.dispatch(splat_, {surfels, grid}, p, group_count(p.surfel_count, 128));
}

void SurfelPipelines::resolve(gpu::CommandList& cmd, const gpu::BufferPtr& surfels, const gpu::BufferPtr& depth_index,
                              const kernels::FramePyramid::Level& out, const gpu::BufferPtr& index_map,
                              const L::ResolveParams& p) const {
  const int w = int(std::min(p.x1, p.width)) - int(p.x0), h = int(std::min(p.y1, p.height)) - int(p.y0);
  if (w <= 0 || h <= 0) return;
  cmd.dispatch(resolve_, {surfels, depth_index, out.vertex, out.normal, out.intensity, index_map}, p, tiles(w), tiles(h));
}

void SurfelPipelines::subsample(gpu::CommandList& cmd, const kernels::FramePyramid::Level& src,
                                const kernels::FramePyramid::Level& dst, const std::optional<PixelRect>& rect) const {
  const PixelRect r = rect ? rect->clamped(dst.width, dst.height) : PixelRect::full(dst.width, dst.height);
  if (r.empty()) return;
  const L::SubsampleParams p{uint32_t(src.width), uint32_t(src.height), uint32_t(dst.width), uint32_t(dst.height),
                             uint32_t(r.x0),      uint32_t(r.y0),       uint32_t(r.x1),      uint32_t(r.y1)};
  cmd.dispatch(subsample_, {src.vertex, src.normal, src.intensity, dst.vertex, dst.normal, dst.intensity}, p,
               tiles(r.width()), tiles(r.height()));
}

namespace {
// A model's counter set to {count, 0, 0, 0} on the GPU, in the submission that uses it (no upload
// and round trip of its own).
void reset_counter(gpu::CommandList& cmd, const gpu::BufferPtr& counter, uint32_t count) {
  cmd.fill(counter, count, 0, sizeof(uint32_t));
  cmd.fill(counter, 0u, sizeof(uint32_t), 3 * sizeof(uint32_t));
  cmd.barrier();
}

// Merge search over the fusion's index map, in the part of the image this fusion covered (the
// index map's rows outside its rectangle are stale).
L::MergeParams merge_params(const L::FuseParams& fp, unsigned surfel_count, const FusionParams& params) {
  if (uint64_t{std::max(fp.width, fp.height)} * fp.grid_scale >= SMALL_QUOTIENT_LIMIT)
    throw Error("merge search: an index map of " + std::to_string(fp.width * fp.grid_scale) + "x" +
                std::to_string(fp.height * fp.grid_scale) + " cells is too large (at most " +
                std::to_string(SMALL_QUOTIENT_LIMIT - 1) + " across)");
  L::MergeParams mp{};
  std::copy(fp.T_camera_model, fp.T_camera_model + 12, mp.T_camera_model);
  mp.fx = fp.fx, mp.fy = fp.fy, mp.cx = fp.cx, mp.cy = fp.cy;
  mp.width = fp.width, mp.height = fp.height, mp.grid_scale = fp.grid_scale;
  mp.surfel_count = surfel_count;
  mp.rect_x0 = fp.rect_x0, mp.rect_y0 = fp.rect_y0, mp.rect_x1 = fp.rect_x1, mp.rect_y1 = fp.rect_y1;
  mp.window_cells = uint32_t(std::max(params.merge_window_cells, 0));
  mp.window_step = uint32_t(std::max(params.merge_window_step_cells, 1));
  mp.distance_rel = params.merge_distance_rel;
  mp.min_normal_dot = float(std::cos(params.merge_max_normal_angle_deg * M_PI / 180.0));
  mp.use_labels = fp.label_mask != FUSE_ALL_LABELS ? 1u : 0u, mp.label_mask = fp.label_mask;
  mp.max_source_confidence = params.merge_max_source_confidence;
  return mp;
}

// Fusion of a model (`surfels`: its count and capacity) at T_camera_model in `area` of the image.
L::FuseParams fuse_params(const Eigen::Isometry3d& T_camera_model, const Intrinsics& k, std::pair<unsigned, unsigned> surfels,
                          int frame, const FusionParams& params, uint32_t label_mask, const PixelRect& area,
                          float colour_gain) {
  L::FuseParams fp{};
  to_rows(T_camera_model, fp.T_camera_model);
  fp.fx = float(k.fx), fp.fy = float(k.fy), fp.cx = float(k.cx), fp.cy = float(k.cy);
  fp.width = uint32_t(k.width), fp.height = uint32_t(k.height);
  fp.grid_scale = uint32_t(params.index_map_scale);
  fp.surfel_count = surfels.first;
  fp.capacity = surfels.second;
  fp.frame = frame;
  fp.max_depth_diff_rel = params.max_depth_diff_rel;
  fp.min_normal_dot = float(std::cos(params.max_normal_angle_deg * M_PI / 180.0));
  fp.max_radius_growth = params.max_radius_growth;
  fp.label_mask = label_mask;
  fp.rect_x0 = uint32_t(area.x0), fp.rect_y0 = uint32_t(area.y0), fp.rect_x1 = uint32_t(area.x1),
  fp.rect_y1 = uint32_t(area.y1);
  fp.colour_gain = colour_gain;
  fp.new_surfel_clearance_cells = uint32_t(std::max(params.new_surfel_clearance_cells, 0));
  return fp;
}

// The splat into fusion's index map (grid_scale cells per pixel): every surfel takes part.
L::SplatParams fusion_splat_params(const L::FuseParams& fp, const FusionParams& params) {
  L::SplatParams sp{};
  std::copy(fp.T_camera_model, fp.T_camera_model + 12, sp.T_camera_model);
  sp.fx = fp.fx, sp.fy = fp.fy, sp.cx = fp.cx, sp.cy = fp.cy;
  sp.width = fp.width * fp.grid_scale, sp.height = fp.height * fp.grid_scale;
  sp.surfel_count = fp.surfel_count;
  sp.min_confidence = 0.0f;
  sp.frame = fp.frame;
  sp.recent_window_frames = 0;
  sp.grid_scale = fp.grid_scale;
  sp.footprint_px = uint32_t(params.index_map_footprint);
  sp.offset_penalty_rel = params.index_map_offset_penalty_rel;
  return sp;
}

// Cleanup after fusion, over up to `most_surfels` surfels (the old ones and the new).
L::CleanupParams cleanup_params(const L::FuseParams& fp, unsigned most_surfels, const FusionParams& params, bool merge) {
  L::CleanupParams cp{};
  std::copy(fp.T_camera_model, fp.T_camera_model + 12, cp.T_camera_model);
  cp.fx = fp.fx, cp.fy = fp.fy, cp.cx = fp.cx, cp.cy = fp.cy;
  cp.width = fp.width, cp.height = fp.height;
  cp.surfel_count = most_surfels;
  cp.frame = fp.frame;
  cp.stable_confidence = params.stable_confidence;
  cp.unstable_window_frames = params.unstable_window_frames;
  cp.free_space_margin_rel = params.free_space_margin_rel;
  cp.free_space_penalty = params.free_space_penalty;
  cp.merge = merge ? 1u : 0u;
  return cp;
}

// FuseParams' pixel rectangle within the image: width and height (0 x 0 when it is empty).
std::pair<uint32_t, uint32_t> rect_size(const L::FuseParams& p) {
  const int w = int(std::min(p.rect_x1, p.width)) - int(p.rect_x0), h = int(std::min(p.rect_y1, p.height)) - int(p.rect_y0);
  return w > 0 && h > 0 ? std::pair(uint32_t(w), uint32_t(h)) : std::pair(0u, 0u);
}

// Workgroups covering the rectangle in 2D tiles (0 when it is empty).
std::pair<uint32_t, uint32_t> rect_tiles(const L::FuseParams& p) {
  const auto [w, h] = rect_size(p);
  return std::pair(tiles(int(w)), tiles(int(h)));
}
}  // namespace

void SurfelPipelines::associate(gpu::CommandList& cmd, const FuseBuffers& b, const L::FuseParams& p) const {
  const auto [gx, gy] = rect_tiles(p);
  if (gx == 0) return;
  cmd.dispatch(associate_, {b.surfels, b.index_map, b.vertex, b.normal, b.rgb, b.assoc, b.claim, b.counter, b.labels}, p,
               gx, gy);
}

void SurfelPipelines::update(gpu::CommandList& cmd, const FuseBuffers& b, const L::FuseParams& p) const {
  const auto [w, h] = rect_size(p);
  const uint32_t blocks = kernels::CompactionScan::block_count(w * h);
  if (blocks == 0) return;
  const auto buffers = {b.surfels, b.index_map, b.vertex, b.normal, b.rgb, b.assoc, b.claim, b.counter, b.labels, b.surfels, b.blocks};
  cmd.dispatch(count_new_, buffers, p, blocks);
  cmd.barrier();
  scan_.record(cmd, b.blocks, b.counter, 0, blocks);
  cmd.barrier();
  cmd.dispatch(update_, buffers, p, blocks);
}

// merge_select and merge_claim run 128 surfels per workgroup (their local_size_x), cleanup and
// its compaction COMPACTION_BLOCK: the first and second of the maintenance groups.
constexpr uint32_t kMergeGroupSize = 128;
constexpr uint32_t kFusedCountSlot = 0;  // counter[0]: the model's count after fusion's new surfels
constexpr size_t kMergeGroupsOffset = 0, kCleanupGroupsOffset = kernels::IndirectGroups::kSecondOffset;

void SurfelPipelines::maintenance_groups(gpu::CommandList& cmd, const gpu::BufferPtr& counter, uint32_t bound,
                                         const gpu::BufferPtr& groups) const {
  groups_.record(cmd, counter, kFusedCountSlot, bound, kMergeGroupSize, COMPACTION_BLOCK, groups);
}

void SurfelPipelines::merge_select(gpu::CommandList& cmd, const MergeBuffers& b, const L::MergeParams& p,
                                   const gpu::BufferPtr& groups) const {
  cmd.dispatch_indirect(merge_select_, {b.surfels, b.index_map, b.target, b.claim, b.counter, b.labels}, p, groups,
                        kMergeGroupsOffset);
}

void SurfelPipelines::merge_claim(gpu::CommandList& cmd, const MergeBuffers& b, const L::MergeParams& p,
                                  const gpu::BufferPtr& groups) const {
  cmd.dispatch_indirect(merge_claim_, {b.surfels, b.index_map, b.target, b.claim, b.counter, b.labels}, p, groups,
                        kMergeGroupsOffset);
}

void SurfelPipelines::compact_kept(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst,
                                   const gpu::BufferPtr& counter, const gpu::BufferPtr& blocks,
                                   const gpu::BufferPtr& keep_mask, uint32_t block_count,
                                   const gpu::BufferPtr& groups) const {
  cmd.barrier();
  scan_.record(cmd, blocks, counter, 1, block_count, groups ? kFusedCountSlot : COMPACTION_FIXED_COUNT);
  cmd.barrier();
  const void* no_params = nullptr;  // surfel_compact has no push constants
  if (groups)
    cmd.dispatch_indirect(compact_, {src, dst, blocks, keep_mask}, no_params, 0, groups, kCleanupGroupsOffset);
  else
    cmd.dispatch(compact_, {src, dst, blocks, keep_mask}, no_params, 0, block_count);
}

void SurfelPipelines::cleanup(gpu::CommandList& cmd, const gpu::BufferPtr& surfels, const gpu::BufferPtr& scratch,
                              const gpu::BufferPtr& depth_m, const gpu::BufferPtr& counter, const gpu::BufferPtr& blocks,
                              const gpu::BufferPtr& keep_mask, const L::CleanupParams& p, const gpu::BufferPtr& groups,
                              const gpu::BufferPtr& merge_target, const gpu::BufferPtr& merge_claim) const {
  const uint32_t block_count = kernels::CompactionScan::block_count(p.surfel_count);
  if (block_count == 0) return;
  const gpu::BufferPtr& target = merge_target ? merge_target : surfels;  // not read without p.merge
  const gpu::BufferPtr& claim = merge_claim ? merge_claim : surfels;
  cmd.dispatch_indirect(cleanup_, {surfels, scratch, depth_m, counter, target, claim, blocks, keep_mask}, p, groups,
                        kCleanupGroupsOffset);
  compact_kept(cmd, scratch, surfels, counter, blocks, keep_mask, block_count, groups);
}

void SurfelPipelines::remove_region(gpu::CommandList& cmd, const gpu::BufferPtr& src, const gpu::BufferPtr& dst,
                                    const gpu::BufferPtr& depth_m, const gpu::BufferPtr& labels,
                                    const gpu::BufferPtr& counter, const gpu::BufferPtr& blocks,
                                    const gpu::BufferPtr& keep_mask, const L::RemoveRegionParams& p) const {
  const uint32_t block_count = kernels::CompactionScan::block_count(p.surfel_count);
  if (block_count == 0) return;
  cmd.dispatch(remove_region_, {src, keep_mask, depth_m, labels, counter, blocks}, p, block_count);
  compact_kept(cmd, src, dst, counter, blocks, keep_mask, block_count);
}

FusionStats SurfelPipelines::fuse(gpu::Stream& stream, SurfelModel& model, const kernels::FramePyramid& live,
                                  const Eigen::Isometry3d& T_camera_model, int frame, const FusionParams& params,
                                  const gpu::BufferPtr& labels, unsigned label,
                                  const std::optional<PixelRect>& rect, float colour_gain, uint32_t also_labels) const {
  const auto& l0 = live.levels.at(0);
  const Intrinsics& k = l0.intrinsics;
  const unsigned pixels = unsigned(k.width) * unsigned(k.height);
  const PixelRect area = rect ? rect->clamped(k.width, k.height) : PixelRect::full(k.width, k.height);
  FusionStats stats;
  // Room for one new surfel per pixel of the rectangle, so fuse_update's new surfels can never
  // overflow; cleanup scans no further.
  const unsigned incoming = unsigned(area.area());
  stats.culled = model.make_room(stream, incoming, params);
  stats.surfels_before = model.count_;
  const unsigned most_surfels = model.count_ + incoming;
  const int S = params.index_map_scale;
  model.ensure_fusion_scratch(pixels, size_t(pixels) * size_t(S) * size_t(S));
  const gpu::BufferPtr& index_map = model.index_map_;

  const uint32_t label_mask = labels ? (label < 32 ? 1u << label : 0u) | also_labels : FUSE_ALL_LABELS;
  const L::FuseParams fp =
      fuse_params(T_camera_model, k, {model.count_, model.capacity_}, frame, params, label_mask, area, colour_gain);
  const L::SplatParams sp = fusion_splat_params(fp, params);
  const bool merge = params.merge_distance_rel > 0.0f && model.count_ > 0;
  const L::CleanupParams cp = cleanup_params(fp, most_surfels, params, merge);
  const L::MergeParams mp = merge_params(fp, most_surfels, params);

  const gpu::BufferPtr& label_buffer = labels ? labels : model.no_labels_;
  // One blocks buffer serves fusion's new surfels (a block per COMPACTION_BLOCK pixels of the
  // rectangle) and then cleanup (per COMPACTION_BLOCK surfels), one after the other.
  const gpu::BufferPtr& blocks = model.compaction_blocks(std::max(incoming, most_surfels));
  const gpu::BufferPtr& keep_mask = model.compaction_keep_mask(most_surfels);
  // Association reads the index-map rows of the rectangle's pixels, the ring of
  // new_surfel_clearance_cells cells around them (fuse_associate's depth_agrees_around), and the
  // claims of existing surfels: nothing else needs clearing. A row left out would hold an earlier
  // frame's surfel indices (or, at first, uninitialised memory).
  const size_t row_bytes = size_t(k.width) * size_t(S) * 8;
  const int ring_rows = (std::max(params.new_surfel_clearance_cells, 0) + S - 1) / S;
  const int clear_y0 = std::max(area.y0 - ring_rows, 0), clear_y1 = std::min(area.y1 + ring_rows, k.height);
  const uint32_t* counter = nullptr;  // read back in the same submission
  stream.run([&](gpu::CommandList& cmd) {
    reset_counter(cmd, model.counter_, model.count_);
    cmd.fill(index_map, 0xFFFFFFFFu, size_t(clear_y0) * size_t(S) * row_bytes,
             size_t(clear_y1 - clear_y0) * size_t(S) * row_bytes);
    cmd.fill(model.claim_, 0xFFFFFFFFu, 0, size_t(model.count_) * 4);
    cmd.barrier();
    cmd.set_profile_label("for fusion");
    splat(cmd, model.surfels_, index_map, sp);
    cmd.set_profile_label("");
    cmd.barrier();
    const FuseBuffers b{model.surfels_, index_map, l0.vertex, l0.normal, live.rgb,
                        model.assoc_,   model.claim_, model.counter_, label_buffer, blocks};
    associate(cmd, b, fp);
    cmd.barrier();
    update(cmd, b, fp);
    cmd.barrier();
    const gpu::BufferPtr& groups = model.maintenance_groups_;
    maintenance_groups(cmd, model.counter_, most_surfels, groups);
    if (merge) {
      const MergeBuffers mb{model.surfels_, index_map, model.merge_target_, model.claim_, model.counter_, label_buffer};
      cmd.fill(model.claim_, 0xFFFFFFFFu, 0, size_t(most_surfels) * 4);  // merge_claim's, after a barrier
      merge_select(cmd, mb, mp, groups);
      cmd.barrier();
      merge_claim(cmd, mb, mp, groups);
      cmd.barrier();
    }
    cleanup(cmd, model.surfels_, model.scratch_, l0.depth_m, model.counter_, blocks, keep_mask, cp, groups,
            model.merge_target_, model.claim_);
    counter = static_cast<const uint32_t*>(stream.record_download(cmd, model.counter_, 4 * sizeof(uint32_t)));
  });
  stats.surfels_after_fusion = std::min(counter[0], model.capacity_);
  stats.surfels_after_cleanup = counter[1];
  model.count_ = counter[1];
  const unsigned most = model.limit(incoming, params.max_surfels);
  if (model.count_ > most) stats.culled += model.cull_least_confident(stream, cull_target(most, params));
  return stats;
}

unsigned SurfelPipelines::remove_region(gpu::Stream& stream, SurfelModel& model, const kernels::FramePyramid& live,
                                        const Eigen::Isometry3d& T_camera_model, const gpu::BufferPtr& labels,
                                        unsigned label, float margin_rel) const {
  const auto& l0 = live.levels.at(0);
  const Intrinsics& k = l0.intrinsics;
  const size_t pixels = size_t(k.width) * size_t(k.height);
  const std::string what = "remove_region on model " + std::to_string(model.id_);
  if (!labels || labels->size() < pixels * 4)
    throw Error(what + ": the label map needs " + std::to_string(pixels) + " uints (" + std::to_string(k.width) + "x" +
                std::to_string(k.height) + ")" + (labels ? ", got " + std::to_string(labels->size() / 4) : std::string()));
  if (!l0.depth_m || l0.depth_m->size() < pixels * 4) throw Error(what + ": the live frame has no level-0 depth");
  if (!std::isfinite(margin_rel)) throw Error(what + ": margin_rel is not finite");
  if (model.count_ == 0) return 0;

  L::RemoveRegionParams p{};
  to_rows(T_camera_model, p.T_camera_model);
  p.fx = float(k.fx), p.fy = float(k.fy), p.cx = float(k.cx), p.cy = float(k.cy);
  p.width = uint32_t(k.width), p.height = uint32_t(k.height);
  p.surfel_count = model.count_;
  p.label = label;
  p.margin_rel = margin_rel;
  const gpu::BufferPtr& blocks = model.compaction_blocks(model.count_);
  const gpu::BufferPtr& keep_mask = model.compaction_keep_mask(model.count_);
  const uint32_t* counter = nullptr;  // read back in the same submission
  stream.run([&](gpu::CommandList& cmd) {
    reset_counter(cmd, model.counter_, model.count_);
    remove_region(cmd, model.surfels_, model.scratch_, l0.depth_m, labels, model.counter_, blocks, keep_mask, p);
    counter = static_cast<const uint32_t*>(stream.record_download(cmd, model.counter_, 4 * sizeof(uint32_t)));
  });
  const unsigned removed = model.count_ - counter[1];
  std::swap(model.surfels_, model.scratch_);
  model.count_ = counter[1];
  return removed;
}

}  // namespace cofusion::slam
