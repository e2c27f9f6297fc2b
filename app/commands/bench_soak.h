#pragma once
// `cofusion bench --soak N`: memory and time per frame over a long run (issue 21, item 4).
//
// The Co-Fusion pipeline (as `bench`'s multi-object figures run it) processes N frames of a
// built-in scene played back and forth: frames 0, 1, ..., n-1, n-2, ..., 1, 0, 1, ... A scene
// looped from its last frame to its first would make the camera jump (static_room: 1.6 m) and
// lose tracking; played back and forth the camera only turns round, where the scene's smooth
// camera path is slowest, so the map sees the same room again and again and should stop
// growing once it has seen it all. Every `report_every_frames` frames a window is closed with
// the resident memory (VmRSS), the device memory the project's buffers hold, surfels per model
// and the mean time per frame; the verdict compares the first window after the map has covered
// the scene (one round trip) with the last one.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "gpu/context.h"
#include "slam/co_fusion.h"

namespace cofusion::commands {

// Growth (last window against the covered-scene window) up to which a figure counts as flat.
struct SoakTolerances {
  double rss_growth_rel = 0.05;      // resident memory
  double device_growth_rel = 0.05;   // device memory of the project's buffers
  double surfels_growth_rel = 0.05;  // all models' surfels
  // Time per frame: the process's CPU time per frame, which other processes on a shared machine
  // do not change (on lavapipe the device's work is this process's threads too); wall-clock time
  // follows the machine's load and is reported only.
  double ms_growth_rel = 0.2;
};

struct SoakOptions {
  int frames = 10000;                               // frames processed in all
  std::string input = "synthetic:static_room";      // a SOURCE as for `run` (played back and forth)
  std::optional<int> source_frames;                 // play only the source's first frames (all: nullopt)
  // Halve the frames (depth nearest-neighbour, colour area-averaged, intrinsics at level 1) as
  // `bench`'s half-resolution figures do: a 10,000-frame soak in a quarter of the time.
  bool half_resolution = false;
  int report_every_frames = 500;                    // window length
  slam::CoFusionParams params;                      // the pipeline's (PipelineConfig defaults)
  SoakTolerances tolerances;
  bool print = true;                                // one line per window and the verdict on stdout
};

struct SoakWindow {
  int first_frame = 0, end_frame = 0;  // frames [first_frame, end_frame) of the run
  double ms_per_frame = 0;             // mean wall-clock time of process() over the window
  double cpu_ms_per_frame = 0;         // mean CPU time of the whole process (all threads) per frame
  double rss_mib = 0;                  // VmRSS at the window's end
  double device_mib = 0;               // gpu::Context::allocated_device_bytes() at the window's end
  std::vector<std::pair<int, unsigned>> surfels;  // (model id, surfels) of the active models at the end
  unsigned total_surfels = 0;
  int lost_frames = 0;                 // camera tracking lost in the window
  // Largest camera position error in the window against the source's ground truth (relative to
  // the first frame's), when the source has ground truth; else -1.
  double max_camera_error_m = -1;
};

struct SoakReport {
  std::string input;
  int width = 0, height = 0;
  int source_frames = 0;      // n: the scene's frames, played back and forth
  int covered_after_frames = 0;  // one round trip: every view seen twice
  std::vector<SoakWindow> windows;
  // Index of the first window starting at or after covered_after_frames (the verdict's
  // baseline); nullopt when no window starts that late (a run too short to tell).
  std::optional<size_t> baseline_window;
  // Last window against the baseline, relative (0.01 = +1 %); ms: wall clock, cpu_ms: CPU time.
  double rss_growth_rel = 0, device_growth_rel = 0, ms_growth_rel = 0, cpu_ms_growth_rel = 0, surfels_growth_rel = 0;
  bool flat = false;  // every growth within SoakTolerances
};

// The source frame played as run frame `i` when `n` frames are played back and forth.
int ping_pong_frame(long i, int n);

// Resident memory of this process (VmRSS of /proc/self/status), MiB; 0 where it cannot be read.
double resident_mib();

// CPU time this process (all its threads) has used so far, milliseconds.
double process_cpu_ms();

// Runs the soak on `ctx`. Throws cofusion::Error on bad options or input.
SoakReport run_soak(gpu::Context& ctx, const SoakOptions& options);

nlohmann::ordered_json to_json(const SoakReport& report);

// `bench`'s soak options: --soak N, --soak-input, --soak-every, ... (the report goes to bench's
// --json FILE when given). Sets the pipeline's parameters to `run`'s defaults.
void add_soak_options(CLI::App& bench, SoakOptions& options);
// The soak on `ctx`, its report written to json_path (when not empty); throws on validation errors.
void bench_soak(gpu::Context& ctx, const SoakOptions& options, const std::string& json_path);

}  // namespace cofusion::commands
