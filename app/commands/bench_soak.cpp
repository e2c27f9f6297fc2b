// `cofusion bench --soak N` (see bench_soak.h).
#include "commands/bench_soak.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "commands/config.h"
#include "commands/sources.h"
#include "io/atomic_file.h"

namespace cofusion::commands {

int ping_pong_frame(long i, int n) {
  if (n <= 1) return 0;
  const long period = 2L * (n - 1);
  const long r = i % period;
  return static_cast<int>(r < n ? r : period - r);
}

double resident_mib() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) != 0) continue;
    std::istringstream fields(line.substr(6));
    double kib = 0;
    fields >> kib;
    return kib / 1024.0;
  }
  return 0.0;
}

double process_cpu_ms() {
  timespec t{};
  if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t) != 0) return 0.0;
  return 1e3 * double(t.tv_sec) + 1e-6 * double(t.tv_nsec);
}

namespace {

constexpr double kMiB = 1024.0 * 1024.0;

// Every frame of `input`, in memory (reading and decoding are not part of the soak), halved on
// request.
std::vector<Frame> load_frames(const std::string& input, std::optional<int> max_frames, bool half) {
  SourceOptions source_options;
  source_options.max_frames = max_frames;
  auto source = open_source(input, source_options);
  std::vector<Frame> frames;
  while (auto frame = source->next()) {
    if (half) {
      cv::resize(frame->depth_m, frame->depth_m, cv::Size(frame->depth_m.cols / 2, frame->depth_m.rows / 2), 0, 0,
                 cv::INTER_NEAREST);
      cv::resize(frame->rgb, frame->rgb, cv::Size(frame->rgb.cols / 2, frame->rgb.rows / 2), 0, 0, cv::INTER_AREA);
      frame->intrinsics = frame->intrinsics.at_level(1);
      frame->mask = cv::Mat();
    }
    if (!frame->depth_m.isContinuous()) frame->depth_m = frame->depth_m.clone();
    if (!frame->rgb.isContinuous()) frame->rgb = frame->rgb.clone();
    frames.push_back(std::move(*frame));
  }
  if (frames.size() < 2) throw Error("bench --soak: need at least 2 frames of " + input);
  return frames;
}

double growth(double before, double after) { return before > 0 ? after / before - 1.0 : 0.0; }

// Accumulates one window's frames.
struct WindowAccumulator {
  int first_frame = 0, frames = 0, lost = 0;
  double total_ms = 0, total_cpu_ms = 0, max_error_m = -1;
};

SoakWindow close_window(const WindowAccumulator& w, const slam::CoFusionFrame& last, const gpu::Context& ctx) {
  SoakWindow out;
  out.first_frame = w.first_frame;
  out.end_frame = w.first_frame + w.frames;
  out.ms_per_frame = w.total_ms / std::max(1, w.frames);
  out.cpu_ms_per_frame = w.total_cpu_ms / std::max(1, w.frames);
  out.rss_mib = resident_mib();
  out.device_mib = double(ctx.allocated_device_bytes()) / kMiB;
  for (const auto& m : last.active) {
    out.surfels.emplace_back(m.id, m.surfels);
    out.total_surfels += m.surfels;
  }
  out.lost_frames = w.lost;
  out.max_camera_error_m = w.max_error_m;
  return out;
}

void print_window(const SoakWindow& w) {
  std::printf("%7d %8.1f %8.1f %10.1f %10.1f %6d %9s %10u  ", w.end_frame, w.ms_per_frame, w.cpu_ms_per_frame, w.rss_mib,
              w.device_mib,
              w.lost_frames,
              w.max_camera_error_m < 0 ? "-" : (std::to_string(int(std::lround(w.max_camera_error_m * 1000))) + " mm").c_str(),
              w.total_surfels);
  for (size_t i = 0; i < w.surfels.size(); ++i)
    std::printf("%s%d:%u", i ? " " : "", w.surfels[i].first, w.surfels[i].second);
  std::printf("\n");
  std::fflush(stdout);
}

void print_verdict(const SoakReport& r, const SoakTolerances& t) {
  if (!r.baseline_window) {
    std::printf("verdict: too short to tell (no window starts after frame %d, when the map has covered the scene)\n",
                r.covered_after_frames);
    return;
  }
  const SoakWindow& b = r.windows[*r.baseline_window];
  const SoakWindow& e = r.windows.back();
  auto line = [](const char* what, double before, double after, double rel, double tolerance, const char* unit) {
    std::printf("  %-15s %10.1f -> %10.1f %-4s %+7.1f %%  %s\n", what, before, after, unit, 100.0 * rel,
                rel <= tolerance ? "flat" : "GROWING");
  };
  std::printf("verdict: window ending at frame %d (the map has covered the scene) against the last, ending at %d\n",
              b.end_frame, e.end_frame);
  line("resident memory", b.rss_mib, e.rss_mib, r.rss_growth_rel, t.rss_growth_rel, "MiB");
  line("device memory", b.device_mib, e.device_mib, r.device_growth_rel, t.device_growth_rel, "MiB");
  line("CPU per frame", b.cpu_ms_per_frame, e.cpu_ms_per_frame, r.cpu_ms_growth_rel, t.ms_growth_rel, "ms");
  std::printf("  %-15s %10.1f -> %10.1f %-4s %+7.1f %%  (wall clock, follows the machine's load; not judged)\n",
              "time per frame", b.ms_per_frame, e.ms_per_frame, "ms", 100.0 * r.ms_growth_rel);
  line("surfels", b.total_surfels, e.total_surfels, r.surfels_growth_rel, t.surfels_growth_rel, "");
  if (r.surfels_growth_rel > t.surfels_growth_rel) {
    const double per_1000 = 1000.0 * (double(e.total_surfels) - double(b.total_surfels)) / double(e.end_frame - b.end_frame);
    std::printf("the map keeps growing: %+.0f surfels per 1000 frames over a scene it has seen (duplicates: issue 22)\n",
                per_1000);
  }
  std::printf("verdict: %s\n", r.flat ? "flat" : "not flat");
}

}  // namespace

SoakReport run_soak(gpu::Context& ctx, const SoakOptions& o) {
  if (o.frames < 1) throw Error("bench --soak: the number of frames must be positive");
  if (o.report_every_frames < 1) throw Error("bench --soak-every: must be positive");
  const std::vector<Frame> frames = load_frames(o.input, o.source_frames, o.half_resolution);
  const Intrinsics k = frames[0].intrinsics;
  SoakReport report;
  report.input = o.input;
  report.width = k.width;
  report.height = k.height;
  report.source_frames = int(frames.size());
  report.covered_after_frames = 2 * (report.source_frames - 1);
  if (o.print) {
    std::printf("soak: %d frames of %s (%dx%d, %d frames played back and forth), a window every %d frames\n", o.frames,
                o.input.c_str(), k.width, k.height, report.source_frames, o.report_every_frames);
    std::printf("%7s %8s %8s %10s %10s %6s %9s %10s  %s\n", "frame", "ms/frame", "CPU ms", "RSS MiB", "device MiB",
                "lost", "max error", "surfels", "model:surfels");
  }

  slam::CoFusion slam(ctx, k, o.params);
  const std::optional<Pose> gt0 = frames[0].T_world_camera_gt;
  WindowAccumulator window;
  slam::CoFusionFrame last;
  for (long i = 0; i < o.frames; ++i) {
    const int index = ping_pong_frame(i, report.source_frames);
    const Frame& f = frames[size_t(index)];
    // A frame played backwards holds the shear of the camera's forward motion while the pipeline
    // sees it move the other way: its colour is not resampled.
    const bool backwards = i > 0 && index < ping_pong_frame(i - 1, report.source_frames);
    slam.note_frame_time(f.timestamp_s, backwards ? 0.0 : f.colour_readout_s);
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start_ms = process_cpu_ms();
    last = slam.process(f.depth_m.ptr<float>(), f.rgb.data);
    window.total_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    window.total_cpu_ms += process_cpu_ms() - cpu_start_ms;
    ++window.frames;
    if (last.camera_state == slam::CameraState::kLost) ++window.lost;
    if (gt0 && f.T_world_camera_gt) {
      const Pose T_first_camera_gt = gt0->inverse() * *f.T_world_camera_gt;
      window.max_error_m =
          std::max(window.max_error_m, (T_first_camera_gt.translation() - last.T_world_camera.translation()).norm());
    }
    if (o.print)
      for (const auto& e : last.events) std::printf("%s\n", e.c_str());
    if (window.frames == o.report_every_frames || i + 1 == o.frames) {
      report.windows.push_back(close_window(window, last, ctx));
      if (o.print) print_window(report.windows.back());
      window = WindowAccumulator{};
      window.first_frame = int(i + 1);
    }
  }

  for (size_t w = 0; w < report.windows.size(); ++w)
    if (report.windows[w].first_frame >= report.covered_after_frames) {
      report.baseline_window = w;
      break;
    }
  if (report.baseline_window) {
    const SoakWindow& b = report.windows[*report.baseline_window];
    const SoakWindow& e = report.windows.back();
    const SoakTolerances& t = o.tolerances;
    report.rss_growth_rel = growth(b.rss_mib, e.rss_mib);
    report.device_growth_rel = growth(b.device_mib, e.device_mib);
    report.ms_growth_rel = growth(b.ms_per_frame, e.ms_per_frame);
    report.cpu_ms_growth_rel = growth(b.cpu_ms_per_frame, e.cpu_ms_per_frame);
    report.surfels_growth_rel = growth(double(b.total_surfels), double(e.total_surfels));
    report.flat = report.rss_growth_rel <= t.rss_growth_rel && report.device_growth_rel <= t.device_growth_rel &&
                  report.cpu_ms_growth_rel <= t.ms_growth_rel && report.surfels_growth_rel <= t.surfels_growth_rel;
  }
  if (o.print) print_verdict(report, o.tolerances);
  return report;
}

nlohmann::ordered_json to_json(const SoakReport& r) {
  nlohmann::ordered_json j;
  j["input"] = r.input;
  j["width"] = r.width;
  j["height"] = r.height;
  j["source_frames"] = r.source_frames;
  j["covered_after_frames"] = r.covered_after_frames;
  j["windows"] = nlohmann::ordered_json::array();
  for (const SoakWindow& w : r.windows) {
    nlohmann::ordered_json jw;
    jw["first_frame"] = w.first_frame;
    jw["end_frame"] = w.end_frame;
    jw["ms_per_frame"] = w.ms_per_frame;
    jw["cpu_ms_per_frame"] = w.cpu_ms_per_frame;
    jw["rss_mib"] = w.rss_mib;
    jw["device_mib"] = w.device_mib;
    jw["total_surfels"] = w.total_surfels;
    jw["surfels"] = nlohmann::ordered_json::array();
    for (const auto& [id, n] : w.surfels) jw["surfels"].push_back({{"model", id}, {"surfels", n}});
    jw["lost_frames"] = w.lost_frames;
    jw["max_camera_error_m"] = w.max_camera_error_m < 0 ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(w.max_camera_error_m);
    j["windows"].push_back(jw);
  }
  if (r.baseline_window) {
    j["baseline_window"] = *r.baseline_window;
    j["growth"] = {{"rss_rel", r.rss_growth_rel},
                   {"device_rel", r.device_growth_rel},
                   {"ms_per_frame_rel", r.ms_growth_rel},
                   {"cpu_ms_per_frame_rel", r.cpu_ms_growth_rel},
                   {"surfels_rel", r.surfels_growth_rel}};
    j["flat"] = r.flat;
  } else {
    j["baseline_window"] = nullptr;
  }
  return j;
}

void add_soak_options(CLI::App& bench, SoakOptions& o) {
  o.params = PipelineConfig{}.cofusion();
  bench
      .add_option("--soak", o.frames,
                  "Only a soak run of N frames: memory, surfels and time per frame every --soak-every frames, "
                  "and whether they stay flat once the map has covered the scene")
      ->check(CLI::PositiveNumber);
  bench.add_option("--soak-input", o.input, "Scene played back and forth in the soak run (a SOURCE as for run)")
      ->capture_default_str();
  bench.add_option("--soak-source-frames", o.source_frames, "Play only the first N frames of --soak-input")
      ->check(CLI::Range(2, 1 << 30));
  bench.add_flag("--soak-half-resolution", o.half_resolution, "Soak at half the source's resolution (4x quicker)");
  bench.add_option("--soak-every", o.report_every_frames, "Soak window length in frames")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
}

void bench_soak(gpu::Context& ctx, const SoakOptions& o, const std::string& json_path) {
  const SoakReport report = run_soak(ctx, o);
  if (!json_path.empty()) write_text_atomically(json_path, to_json(report).dump(2) + "\n");
  if (ctx.validation_error_count() > 0) throw Error(std::to_string(ctx.validation_error_count()) + " Vulkan validation errors");
}

}  // namespace cofusion::commands
