// `cofusion bench`: per-stage wall-clock timings on the chosen Vulkan device, each pipeline
// figure also as a ratio to OpenCV's frame-to-frame odometry on the same frames in the same run;
// --json writes every figure.
#include <cstdio>
#include <nlohmann/json.hpp>

#include "commands/bench_soak.h"
#include "commands/commands.h"
#include "commands/frame_upload.h"
#include "commands/gpu_options.h"
#include "commands/odometry_peer.h"
#include "commands/stage_timer.h"
#include "commands/sources.h"
#include "io/atomic_file.h"
#include "kernels/preprocess.h"
#include "commands/config.h"
#include "commands/semantic_source.h"
#include "slam/co_fusion.h"
#include "slam/dense_slam.h"
#include <map>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

namespace cofusion::commands {
namespace {
using Json = nlohmann::ordered_json;

struct BenchOptions {
  GpuCliOptions gpu;
  int iterations = 30;
  int warmup = 3;
  std::string input = "synthetic:static_room";  // frames for the whole-pipeline figures
  int frames = 50;
  bool kernels = true;   // per-kernel figures
  bool pipeline = true;  // whole-frame figures
  // Multi-object figures: scenes run through the whole Co-Fusion pipeline, frames grouped by
  // the number of active models.
  std::vector<std::string> model_inputs = {"synthetic:static_room", "synthetic:two_objects", "synthetic:five_objects"};
  bool models = true;
  // GPU time per kernel (timestamp queries) beside the pipeline and multi-object tables.
  bool kernel_profile = false;
  // Semantic figures: this scene (it has instance masks) in each segmentation mode, with its own
  // masks and with the built-in detector (when its models are there).
  std::string semantic_input = "synthetic:table_placement";
  bool semantic = true;
  std::string json_file;  // --json: every figure, machine-readable; empty = none
  std::string config_file;  // --config: pipeline parameters as for `cofusion run` (empty: defaults)
  PipelineConfig config;
  // --soak N: only the soak run (bench_soak.h), N frames; its report goes to json_file when set.
  SoakOptions soak{.frames = 0};
};

// Per-kernel GPU time summed over frames (see gpu/kernel_profile.h).
struct KernelTimes {
  std::map<std::string, gpu::KernelProfile::Entry> entries;
  size_t frames = 0;
  void add_frame(const std::map<std::string, gpu::KernelProfile::Entry>& frame) {
    for (const auto& [key, e] : frame) {
      entries[key].total_ms += e.total_ms;
      entries[key].calls += e.calls;
    }
    ++frames;
  }
};

// Kernels by GPU time per frame, largest first, and their sum (on lavapipe, which runs one
// dispatch at a time, the sum is the frame's GPU-busy time).
Json print_kernel_table(const KernelTimes& k) {
  if (k.frames == 0 || k.entries.empty()) return nullptr;
  std::vector<std::pair<std::string, gpu::KernelProfile::Entry>> rows(k.entries.begin(), k.entries.end());
  std::sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.second.total_ms > b.second.total_ms; });
  const double n = double(k.frames);
  std::printf("GPU time per kernel (timestamp queries), per frame over %zu frames\n", k.frames);
  std::printf("%-50s %12s %10s %10s\n", "stream group: kernel", "calls/frame", "ms/call", "ms/frame");
  double sum = 0;
  Json json = {{"frames", k.frames}, {"kernels", Json::array()}};
  for (const auto& [key, e] : rows) {
    std::printf("%-50s %12.1f %10.3f %10.3f\n", key.c_str(), double(e.calls) / n, e.total_ms / double(e.calls),
                e.total_ms / n);
    json["kernels"].push_back({{"kernel", key},
                               {"calls_per_frame", double(e.calls) / n},
                               {"ms_per_call", e.total_ms / double(e.calls)},
                               {"ms_per_frame", e.total_ms / n}});
    sum += e.total_ms;
  }
  std::printf("%-50s %12s %10s %10.3f\n", "all kernels", "", "", sum / n);
  json["all_kernels_ms_per_frame"] = sum / n;
  return json;
}

// Halves a frame (and its intrinsics) for the 320x240 figures: depth by nearest neighbour, so
// no depths are mixed across edges; colour by area averaging.
Frame half_resolution(const Frame& f) {
  Frame h = f;
  cv::resize(f.depth_m, h.depth_m, cv::Size(f.depth_m.cols / 2, f.depth_m.rows / 2), 0, 0, cv::INTER_NEAREST);
  cv::resize(f.rgb, h.rgb, cv::Size(f.rgb.cols / 2, f.rgb.rows / 2), 0, 0, cv::INTER_AREA);
  h.intrinsics = f.intrinsics.at_level(1);
  return h;
}

// A pipeline figure over the peer's: how many times OpenCV's odometry time per frame it takes.
double peer_ratio(double ms, const OdometryPeerFigure& peer) { return ms / peer.median_ms; }

// The table of `times` (median, min, max ms per stage, and with `peer` the median's ratio to it),
// printed and returned as JSON rows.
Json print_table(const StageTimes& times, const OdometryPeerFigure* peer = nullptr) {
  std::printf("%-34s %10s %10s %10s%s\n", "stage", "median ms", "min ms", "max ms", peer ? "   x OpenCV" : "");
  Json rows = Json::array();
  for (const auto& stage : times.stages()) {
    const auto& s = times.samples(stage);
    const double median = times.median(stage), min = *std::min_element(s.begin(), s.end()),
                 max = *std::max_element(s.begin(), s.end());
    std::printf("%-34s %10.3f %10.3f %10.3f", stage.c_str(), median, min, max);
    Json row = {{"stage", stage}, {"median_ms", median}, {"min_ms", min}, {"max_ms", max}};
    if (peer) {
      std::printf(" %10.2fx", peer_ratio(median, *peer));
      row["ratio"] = peer_ratio(median, *peer);
    }
    std::printf("\n");
    rows.push_back(std::move(row));
  }
  return rows;
}

// Times OpenCV's odometry on `frames`, says so and returns the figure with its JSON.
OdometryPeerFigure print_peer(const std::vector<Frame>& frames, Json& json) {
  const OdometryPeerFigure peer = time_opencv_odometry(frames);
  std::printf("OpenCV %s on these frames: %.3f ms per frame (median of %d frames%s)\n", opencv_odometry_name(),
              peer.median_ms, peer.frames,
              peer.failures ? (", " + std::to_string(peer.failures) + " without a pose").c_str() : "");
  json["opencv_odometry"] = {{"median_ms", peer.median_ms}, {"frames", peer.frames}, {"failures", peer.failures}};
  return peer;
}

// The whole pipeline (upload, preprocess, predict, track, fuse) over frames held in memory, so
// that reading and decoding files is not timed. The first frames (model start-up, pipeline
// compilation) are not counted.
Json bench_pipeline(gpu::Context& ctx, const std::vector<Frame>& frames, const std::string& label,
                    const PipelineConfig& config) {
  if (frames.size() < 4) throw Error("bench: need at least 4 frames of input for the pipeline figures");
  const Intrinsics k = frames[0].intrinsics;
  Json json = {{"label", label}, {"width", k.width}, {"height", k.height}, {"frames", frames.size()}};
  slam::DenseSlam slam(ctx, k, config.slam);
  StageTimes times;
  KernelTimes kernel_times;
  const size_t skip = 2;
  for (size_t i = 0; i < frames.size(); ++i) {
    slam.note_frame_time(frames[i].timestamp_s, frames[i].colour_readout_s);  // as `run` does
    const auto start = std::chrono::steady_clock::now();
    const auto r = slam.process(frames[i].depth_m.ptr<float>(), frames[i].rgb.data);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    // A frame's work is finished when process() returns; its timings are collected with it.
    const auto kernels = ctx.kernel_profile() ? ctx.kernel_profile()->take() : decltype(kernel_times.entries){};
    if (i < skip) continue;
    if (ctx.kernel_profile()) kernel_times.add_frame(kernels);
    for (const auto& [stage, stage_ms] : r.stage_ms) times.add(stage, stage_ms);
    times.add("whole frame", ms);
  }
  std::printf("\npipeline %s (%dx%d, %zu frames, first %zu not counted), %u surfels at the end\n", label.c_str(), k.width,
              k.height, frames.size(), skip, slam.model().count());
  json["frames_not_counted"] = skip;
  json["surfels_at_end"] = slam.model().count();
  // After the pipeline, moments apart: both figures catch the same phase of this machine.
  const OdometryPeerFigure peer = print_peer(frames, json);
  json["stages"] = print_table(times, &peer);
  const double median_ms = times.median("whole frame"), mean_ms = times.mean("whole frame");
  std::printf("frames per second: %.2f (median frame), %.2f (mean frame); median frame %.2fx OpenCV odometry\n",
              1000.0 / median_ms, 1000.0 / mean_ms, peer_ratio(median_ms, peer));
  json["whole_frame"] = {{"median_ms", median_ms}, {"mean_ms", mean_ms}, {"fps_median_frame", 1000.0 / median_ms},
                         {"fps_mean_frame", 1000.0 / mean_ms}, {"ratio", peer_ratio(median_ms, peer)}};
  if (Json kernels = print_kernel_table(kernel_times); !kernels.is_null()) json["gpu_kernels"] = std::move(kernels);
  return json;
}

// Every frame of `input` (at most max_frames), in memory.
std::vector<Frame> read_frames(const std::string& input, int max_frames) {
  SourceOptions source_options;
  source_options.max_frames = max_frames;
  auto source = open_source(input, source_options);
  std::vector<Frame> frames;
  while (auto frame = source->next()) {
    if (!frame->depth_m.isContinuous()) frame->depth_m = frame->depth_m.clone();
    if (!frame->rgb.isContinuous()) frame->rgb = frame->rgb.clone();
    frames.push_back(std::move(*frame));
  }
  if (frames.size() < 4) throw Error("bench: need at least 4 frames of " + input);
  return frames;
}

// Frames at each end of a run whose medians bench_models compares (issue 22: time per frame over
// TUM fr1/rpy-200 may vary by less than 20 % between its first and last 50 frames).
constexpr size_t kFirstLastFrames = 50;

// Co-Fusion over a scene (motion segmentation, lifecycle, one model per moving object): every
// frame is timed and grouped by the number of models tracked in it, so the figures read as "fps
// with N models"; also the medians of the first and last kFirstLastFrames counted frames.
// Superpixels run on the CPU job system while the GPU tracks; the overlap column says how much of
// that time was hidden behind GPU work.
Json bench_models(gpu::Context& ctx, const std::string& input, int max_frames, const PipelineConfig& config) {
  const std::vector<Frame> frames = read_frames(input, max_frames);
  const Intrinsics k = frames[0].intrinsics;
  slam::CoFusion slam(ctx, k, config.cofusion());
  std::map<size_t, StageTimes> by_models;
  std::map<size_t, KernelTimes> kernels_by_models;
  std::vector<double> frame_ms;  // every counted frame, in order
  for (size_t i = 0; i < frames.size(); ++i) {
    slam.note_frame_time(frames[i].timestamp_s, frames[i].colour_readout_s);  // as `run` does
    const auto start = std::chrono::steady_clock::now();
    const auto r = slam.process(frames[i].depth_m.ptr<float>(), frames[i].rgb.data);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    const auto kernels = ctx.kernel_profile() ? ctx.kernel_profile()->take() : decltype(KernelTimes::entries){};
    if (i < 2) continue;  // start-up: pipeline compilation, first fusion
    size_t tracked = 0;
    for (const auto& m : r.active) tracked += m.tracked;
    if (ctx.kernel_profile()) kernels_by_models[tracked].add_frame(kernels);
    StageTimes& times = by_models[tracked];
    for (const auto& [stage, stage_ms] : r.stage_ms) times.add(stage, stage_ms);
    times.add("  superpixels (CPU job)", r.superpixels_ms);
    times.add("  of which overlapped GPU work", r.superpixels_overlap_ms);
    // Only where the device runs them beside the GPU's work (CoFusionParams::host_overlap).
    if (r.crf_nodes_ms > 0) times.add("  of which CRF nodes and kernels", r.crf_nodes_ms);
    times.add("  segmentation after tracking", r.segment_ms);
    for (const auto& [part, part_ms] : r.segment_parts_ms) times.add("    " + part, part_ms);
    for (const auto& [part, part_ms] : r.lifecycle_parts_ms) times.add("      " + part, part_ms);
    times.add("whole frame", ms);
    frame_ms.push_back(ms);
  }
  std::printf("\nmulti-object pipeline on %s (%dx%d, %zu frames, first 2 not counted)\n", input.c_str(),
              k.width, k.height, frames.size());
  Json json = {{"input", input}, {"width", k.width}, {"height", k.height}, {"frames", frames.size()},
               {"frames_not_counted", 2}};
  const OdometryPeerFigure peer = print_peer(frames, json);
  json["by_active_models"] = Json::array();
  for (const auto& [models, times] : by_models) {
    const double median_ms = times.median("whole frame");
    std::printf("\n%zu active model%s, %zu frames: %.2f frames per second (median frame, %.2fx OpenCV odometry)\n",
                models, models == 1 ? "" : "s", times.samples("whole frame").size(), 1000.0 / median_ms,
                peer_ratio(median_ms, peer));
    Json group = {{"active_models", models},
                  {"frames", times.samples("whole frame").size()},
                  {"median_ms", median_ms},
                  {"fps_median_frame", 1000.0 / median_ms},
                  {"ratio", peer_ratio(median_ms, peer)}};
    group["stages"] = print_table(times, &peer);
    if (auto it = kernels_by_models.find(models); it != kernels_by_models.end())
      if (Json kernels = print_kernel_table(it->second); !kernels.is_null()) group["gpu_kernels"] = std::move(kernels);
    json["by_active_models"].push_back(std::move(group));
  }
  if (const auto m = first_last_medians(frame_ms, kFirstLastFrames)) {
    std::printf("\ntime per frame over the run: median of the first %zu counted frames %.1f ms, of the last %zu %.1f ms (%+.0f %%)\n",
                m->window, m->first_ms, m->window, m->last_ms, 100.0 * m->change());
    json["first_last"] = {{"window_frames", m->window}, {"first_median_ms", m->first_ms},
                          {"last_median_ms", m->last_ms}, {"change", m->change()}};
  }
  return json;
}

// One segmentation mode with one source of instance masks over `frames`, as `cofusion run` does
// it (the detector asynchronous, each frame given the latest detection, made from an earlier frame).
Json bench_semantic_mode(gpu::Context& ctx, const std::vector<Frame>& frames, const OdometryPeerFigure& peer,
                         slam::SegmentationMode mode, const std::string& masks, int detector_every = 1) {
  slam::CoFusionParams params = PipelineConfig{}.cofusion();
  params.semantic.mode = mode;
  slam::CoFusion slam(ctx, frames[0].intrinsics, params);
  FrameMasks frame_masks(masks, true, frames[0].intrinsics, /*wait_for_detections=*/true, detector_every);
  StageTimes times;
  for (size_t i = 0; i < frames.size(); ++i) {
    const Frame& f = frames[i];
    slam.note_frame_time(f.timestamp_s, f.colour_readout_s);
    const auto start = std::chrono::steady_clock::now();
    slam.process(f.depth_m.ptr<float>(), f.rgb.data, frame_masks.for_frame(f, f.rgb, f.depth_m));
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (i >= 2) times.add("whole frame", ms);  // start-up: pipeline compilation, first fusion
  }
  const std::string source = detector_every > 1 ? masks + " 1/" + std::to_string(detector_every) : masks;
  // The mean, not the median: with a detection every few frames the frames that wait for one are
  // a minority, and they are part of the cost.
  const double mean_ms = times.mean("whole frame"), median_ms = times.median("whole frame");
  std::printf("  %-9s %-12s %6.2f fps (mean frame %6.1f ms, median %6.1f ms; mean %.2fx OpenCV odometry)",
              slam::to_string(mode), source.c_str(), 1000.0 / mean_ms, mean_ms, median_ms, peer_ratio(mean_ms, peer));
  Json json = {{"segmentation", slam::to_string(mode)}, {"masks", masks}, {"detector_every", detector_every},
               {"frames", times.samples("whole frame").size()}, {"mean_ms", mean_ms}, {"median_ms", median_ms},
               {"fps_mean_frame", 1000.0 / mean_ms}, {"ratio", peer_ratio(mean_ms, peer)}};
  if (const AsyncDetector* detector = frame_masks.detector()) {
    std::printf("; detector %.0f ms per run, ran on %d of %zu frames", detector->mean_detection_ms(),
                detector->detections_started(), frames.size());
    json["detector"] = {{"ms_per_run", detector->mean_detection_ms()}, {"runs", detector->detections_started()}};
  }
  std::printf("\n");
  return json;
}

// fps per segmentation mode and mask source (issue: semantic instance segmentation, benchmark).
// The ratios divide the mean frame (the figure these lines quote) by OpenCV's median frame.
Json bench_semantic(gpu::Context& ctx, const std::string& input, int max_frames) {
  const std::vector<Frame> frames = read_frames(input, max_frames);
  std::printf("\nsegmentation modes on %s (%zu frames, first 2 not counted)\n", input.c_str(), frames.size());
  Json json = {{"input", input}, {"frames", frames.size()}, {"frames_not_counted", 2}};
  const OdometryPeerFigure peer = print_peer(frames, json);
  json["modes"] = Json::array();
  const auto mode_figure = [&](slam::SegmentationMode mode, const std::string& masks, int detector_every = 1) {
    json["modes"].push_back(bench_semantic_mode(ctx, frames, peer, mode, masks, detector_every));
  };
  mode_figure(slam::SegmentationMode::kMotion, "none");
  const bool has_masks = !frames[0].mask.empty();
  std::error_code ec;
  const bool has_detector = std::filesystem::is_regular_file(default_models_dir() / "centernet.pb", ec);
  // Motion mode with masks too (they exclude people; a run's default where the detector's models
  // are in place): the figure the other modes compare with at the same mask source.
  for (const auto mode : {slam::SegmentationMode::kMotion, slam::SegmentationMode::kSemantic, slam::SegmentationMode::kBoth}) {
    if (has_masks) mode_figure(mode, "masks");
    if (has_detector) mode_figure(mode, "detector");
    if (has_detector) mode_figure(mode, "detector", 4);
  }
  if (!has_detector) std::printf("  (no detector figures: its models are not in %s)\n", default_models_dir().c_str());
  return json;
}

// Times `record` submitted alone, `iterations` times, after `warmup` untimed runs (the first
// dispatch of a pipeline compiles it on Mesa).
template <typename Record>
void time_stage(gpu::Stream& stream, StageTimes& times, const std::string& stage, const BenchOptions& o,
                Record&& record) {
  for (int i = 0; i < o.warmup + o.iterations; ++i) {
    auto start = std::chrono::steady_clock::now();
    stream.run(record);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (i >= o.warmup) times.add(stage, ms);
  }
}

void bench_preprocessing(gpu::Context& ctx, const Intrinsics& k, const BenchOptions& o, StageTimes& times) {
  gpu::Stream stream(ctx, 0, "bench");
  kernels::Preprocessor pre(ctx);
  const kernels::PreprocessParams params = slam::SlamParams{}.effective_preprocess();  // as the pipeline runs it
  auto frame = kernels::FramePyramid::allocate(ctx, k, params.pyramid_levels, "bench frame");
  const Frame input = make_builtin_test_frame(k);
  const std::string size = std::to_string(k.width) + "x" + std::to_string(k.height);
  {
    for (int i = 0; i < o.warmup + o.iterations; ++i) {
      auto start = std::chrono::steady_clock::now();
      upload_frame(stream, input, frame);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      if (i >= o.warmup) times.add("upload " + size, ms);
    }
  }
  const auto& l0 = frame.levels[0];
  const int w = l0.width, h = l0.height;
  time_stage(stream, times, "depth_to_metres " + size, o, [&](gpu::CommandList& c) {
    pre.depth_to_metres(c, frame.raw_depth, frame.depth_raw_m, w, h, kUploadMetresPerUnit, params.min_depth_m,
                        params.max_depth_m);
  });
  time_stage(stream, times, "bilateral_depth " + size, o, [&](gpu::CommandList& c) {
    pre.bilateral_depth(c, frame.depth_raw_m, l0.depth_m, w, h, params.bilateral_radius_px,
                        params.bilateral_sigma_space_px, params.bilateral_sigma_depth_m);
  });
  time_stage(stream, times, "rgb_to_intensity " + size, o,
             [&](gpu::CommandList& c) { pre.rgb_to_intensity(c, frame.rgb, l0.intensity, w, h); });
  time_stage(stream, times, "depth_pyramid (3 levels)", o, [&](gpu::CommandList& c) {
    for (size_t l = 1; l < frame.levels.size(); ++l) {
      pre.downsample_depth(c, frame.levels[l - 1].depth_m, frame.levels[l].depth_m, frame.levels[l - 1].width,
                           frame.levels[l - 1].height, params.pyramid_max_depth_diff_m);
      c.barrier();
    }
  });
  time_stage(stream, times, "intensity_pyramid (3 levels)", o, [&](gpu::CommandList& c) {
    for (size_t l = 1; l < frame.levels.size(); ++l) {
      pre.downsample_intensity(c, frame.levels[l - 1].intensity, frame.levels[l].intensity, frame.levels[l - 1].width,
                               frame.levels[l - 1].height);
      c.barrier();
    }
  });
  time_stage(stream, times, "vertex_normal_map " + size, o, [&](gpu::CommandList& c) {
    pre.vertex_normal_map(c, l0.depth_m, l0.vertex, l0.normal, l0.intrinsics);
  });
  time_stage(stream, times, "vertex_normal_map (all levels)", o, [&](gpu::CommandList& c) {
    for (auto& level : frame.levels) pre.vertex_normal_map(c, level.depth_m, level.vertex, level.normal, level.intrinsics);
  });
  time_stage(stream, times, "intensity_gradient " + size, o,
             [&](gpu::CommandList& c) { pre.intensity_gradient(c, l0.intensity, l0.gradient, w, h); });
  time_stage(stream, times, "preprocess whole frame " + size, o,
             [&](gpu::CommandList& c) { pre.record_frame(c, frame, kUploadMetresPerUnit, params); });
}

}  // namespace

void add_bench(CLI::App& app) {
  auto options = std::make_shared<BenchOptions>();
  auto* cmd = app.add_subcommand("bench", "Time each pipeline stage and print median milliseconds per stage");
  options->gpu.add_to(*cmd);
  cmd->add_option("--iterations", options->iterations, "Timed repetitions per stage")->check(CLI::PositiveNumber);
  cmd->add_option("--warmup", options->warmup, "Untimed repetitions first (pipeline compilation)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--input", options->input, "Frames for the whole-pipeline figures (a SOURCE as for run)");
  cmd->add_option("--frames", options->frames, "How many frames of --input to run")->check(CLI::PositiveNumber);
  cmd->add_flag("!--no-kernels", options->kernels, "Skip the per-kernel figures");
  cmd->add_flag("!--no-pipeline", options->pipeline, "Skip the whole-pipeline figures");
  cmd->add_option("--models-input", options->model_inputs, "Scenes for the multi-object figures (SOURCEs as for run)");
  cmd->add_flag("!--no-models", options->models, "Skip the multi-object figures");
  cmd->add_option("--semantic-input", options->semantic_input,
                  "Scene for the per-segmentation-mode figures (a SOURCE as for run; its masks are used where it has them)");
  cmd->add_flag("!--no-semantic", options->semantic, "Skip the per-segmentation-mode figures");
  cmd->add_flag("--kernel-profile", options->kernel_profile,
                "Also print GPU time per kernel for the pipeline and multi-object figures (timestamp queries)");
  cmd->add_option("--config", options->config_file,
                  "Pipeline and multi-object figures with these parameters (JSON, as for run; default: the defaults)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--json", options->json_file,
                  "Also write every figure (ms, fps, ratio to OpenCV's odometry; with --soak, the soak report) to this JSON file");
  add_soak_options(*cmd, options->soak);
  cmd->callback([options] {
    if (handle_list_devices(options->gpu)) return;
    if (!options->config_file.empty()) options->config = load_config(options->config_file);
    const std::filesystem::path json_file = options->json_file;
    if (!json_file.empty()) ensure_writable_directory(json_file.has_parent_path() ? json_file.parent_path() : ".");
    gpu::Context ctx(options->gpu.context_options());
    std::printf("device: %s\n", ctx.description().c_str());
    Json json = {{"device", ctx.description()},
                 {"ratio", std::string("pipeline milliseconds / milliseconds per frame of OpenCV ") +
                               opencv_odometry_name() + " on the same frames, measured in this run (" +
                               std::to_string(cv::getNumThreads()) + " OpenCV threads)"}};
    if (options->soak.frames > 0) return bench_soak(ctx, options->soak, options->json_file);
    if (options->kernels) {
      StageTimes times;
      bench_preprocessing(ctx, Intrinsics{}, *options, times);
      std::printf("\nkernels (built-in test frame)\n");
      json["kernels"] = {{"input", "built-in test frame 640x480"}, {"stages", print_table(times)}};
      const double frame_ms = times.median("upload 640x480") + times.median("preprocess whole frame 640x480");
      std::printf("preprocessing throughput: %.1f frames per second (upload + whole-frame preprocessing)\n",
                  1000.0 / frame_ms);
      json["kernels"]["preprocessing_fps"] = 1000.0 / frame_ms;
    }
    // Attached after the per-kernel figures: their wall-clock timings should not include queries.
    if (options->kernel_profile) ctx.set_kernel_profile(std::make_shared<gpu::KernelProfile>());
    if (options->pipeline) {
      SourceOptions source_options;
      source_options.max_frames = options->frames;
      auto source = open_source(options->input, source_options);
      std::printf("input: %s\n", source->describe().c_str());
      std::vector<Frame> full, half;
      while (auto frame = source->next()) {
        if (!frame->depth_m.isContinuous()) frame->depth_m = frame->depth_m.clone();
        if (!frame->rgb.isContinuous()) frame->rgb = frame->rgb.clone();
        half.push_back(half_resolution(*frame));
        full.push_back(std::move(*frame));
      }
      json["pipeline"] = Json::array();
      for (auto [frames, label] : {std::pair{&full, "full resolution"}, std::pair{&half, "half resolution"}}) {
        json["pipeline"].push_back(bench_pipeline(ctx, *frames, label, options->config));
        json["pipeline"].back()["input"] = options->input;
      }
    }
    if (options->models) {
      json["models"] = Json::array();
      for (const auto& input : options->model_inputs) json["models"].push_back(bench_models(ctx, input, options->frames, options->config));
    }
    if (options->semantic) json["semantic"] = bench_semantic(ctx, options->semantic_input, options->frames);
    if (ctx.validation_error_count() > 0) throw Error(std::to_string(ctx.validation_error_count()) + " Vulkan validation errors");
    if (!json_file.empty()) {
      write_text_atomically(json_file, json.dump(2) + "\n");
      std::printf("\nwrote %s\n", json_file.c_str());
    }
  });
}

}  // namespace cofusion::commands
