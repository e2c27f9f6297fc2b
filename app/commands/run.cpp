// `cofusion run`: the main job. Reads frames from a source, processes them on the Vulkan device
// and writes the results under --output.
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <unistd.h>

#include "commands/commands.h"
#include "commands/config.h"
#include "commands/frame_gate.h"
#include "commands/gpu_options.h"
#include "commands/progress.h"
#include "commands/run_report.h"
#include "commands/semantic_source.h"
#include "commands/sources.h"
#include "commands/stage_timer.h"
#include "commands/stop_signals.h"
#include "eval/trajectory_metrics.h"
#include "io/atomic_file.h"
#include "io/instance_classes.h"
#include "io/output_folder.h"
#include "export/model_export.h"
#include "io/trajectory.h"
#include "renderer/overlay.h"
#include "renderer/viewer.h"
#include "slam/co_fusion.h"

namespace cofusion::commands {
namespace {
namespace fs = std::filesystem;

struct RunOptions {
  std::string input = "synthetic";
  std::string output = "./cofusion-out";
  bool headless = false;
  std::optional<int> max_frames;
  FrameGateParams frame_gate;  // --strict
  std::string config_file;
  bool save_segmentation = false;
  std::string intrinsics;
  std::optional<double> depth_correction;
  unsigned seed = 0;
  std::string screenshot;
  // Instance masks (slam::SemanticParams).
  std::string segmentation = "motion";
  std::string semantic_source;  // masks | detector | none; empty = masks when the input has them, else detector
  std::string exclude = "person";
  int detector_every = 1;  // detections start on every this many frames
  std::string classes;
  GpuCliOptions gpu;
};

// The live frame as the viewer's insets: colour, depth (grey, near = bright, up to 5 m) and the
// segmentation (model label colours; black = no model), subsampled to a quarter size.
std::vector<renderer::Inset> live_insets(const Frame& frame, const std::vector<uint16_t>& model_ids) {
  constexpr int kStep = 4;
  const int w = std::max(1, frame.rgb.cols / kStep), h = std::max(1, frame.rgb.rows / kStep);
  renderer::Inset rgb{renderer::Image(w, h), "live rgb"}, depth{renderer::Image(w, h), "depth"},
      labels{renderer::Image(w, h), "segmentation"};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const cv::Vec3b c = frame.rgb.at<cv::Vec3b>(y * kStep, x * kStep);
      rgb.image.at(x, y) = renderer::rgba8(c[0], c[1], c[2]);
      const float d = frame.depth_m.at<float>(y * kStep, x * kStep);
      const bool valid = d > 0.0f;
      const auto g = static_cast<uint32_t>(valid ? std::clamp(255.0f * (1.0f - d / 5.0f), 30.0f, 255.0f) : 0.0f);
      depth.image.at(x, y) = renderer::rgba8(g, g, g);
      const size_t i = size_t(y * kStep) * size_t(frame.rgb.cols) + size_t(x * kStep);
      const int id = i < model_ids.size() ? model_ids[i] : (valid ? 0 : 0xFFFF);
      labels.image.at(x, y) = id != 0xFFFF ? renderer::model_colour(id) : renderer::rgba8(0, 0, 0);
    }
  return {rgb, depth, labels};
}

// The final view for --screenshot without a window: from behind and above the last camera pose,
// looking where it looked, with the trajectory, the camera frustum and model boxes drawn in.
renderer::VirtualCamera overview_camera(const Intrinsics& intrinsics, const Pose& T_world_camera) {
  const Eigen::Vector3d centre = T_world_camera.translation();
  const Eigen::Vector3d forward = T_world_camera.linear().col(2), down = T_world_camera.linear().col(1);
  renderer::VirtualCamera camera;
  camera.intrinsics = intrinsics;
  camera.T_world_view = renderer::look_at(centre - 0.8 * forward - 0.5 * down, centre + 1.5 * forward, -down);
  return camera;
}

// segmentation/classes.txt: the class of every model the run ended with, by the model id its label
// images carry (models deleted or merged away before the end are not listed).
void write_segmentation_classes(const fs::path& path, const std::vector<slam::ModelSnapshot>& snapshots) {
  InstanceClasses classes;
  for (const auto& m : snapshots) {
    if (m.id < 0 || m.id >= 0xFFFF)
      throw Error("model id " + std::to_string(m.id) + " does not fit a 16-bit label image");
    classes.name_by_id[static_cast<std::uint16_t>(m.id)] = class_name_token(m.class_name);
  }
  write_instance_classes(path, classes);
}

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    if (comma > start) out.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

// The camera's ATE against the input's ground truth (the poses of the processed frames that have
// one); nullopt when fewer than two stamps match, as evaluate_ate.py needs (the report never fails
// the run).
std::optional<CameraAccuracy> camera_accuracy(const Trajectory& groundtruth, const Trajectory& camera) {
  if (groundtruth.size() < 2) return std::nullopt;
  try {
    const eval::AteResult ate = eval::compute_ate(groundtruth, camera);
    return CameraAccuracy{ate.translation_m.rmse, ate.errors_m.size()};
  } catch (const Error&) {
    return std::nullopt;
  }
}

// The final table's rows: snapshots[k] with the surfels of models[k] (empty when the device could
// not hand the models back), the files write_models() wrote and, for objects, the trajectory file
// when the model trajectories were written.
std::vector<ModelRow> model_rows(const std::vector<slam::ModelSnapshot>& snapshots,
                                 const std::vector<SurfelCloud>& models, const std::vector<fs::path>& written,
                                 const fs::path& out_dir, bool trajectories_written) {
  std::vector<ModelRow> rows;
  for (size_t k = 0; k < snapshots.size(); ++k) {
    const auto& m = snapshots[k];
    const bool has_trajectory = trajectories_written && m.id != 0;
    rows.push_back({.id = m.id,
                    .class_name = class_name_token(m.class_name),
                    .state = slam::to_string(m.state),
                    .surfels = k < models.size() ? models[k].surfels.size() : 0,
                    .first_frame = m.first_frame,
                    .last_frame = m.last_frame,
                    .files = model_files_cell(written, out_dir, m.id),
                    .trajectory = has_trajectory ? "trajectories/model-" + std::to_string(m.id) + ".txt" : "-"});
  }
  return rows;
}

// The exit status: 0, or 128 + the signal that stopped the run (its outputs written).
// What summary.json reports of a run (see the README's Outputs).
struct SummaryInputs {
  int frames = 0;
  const std::string& stop_reason;  // empty: the run reached the end of its input
  double seconds = 0;
  std::string device, input;
  const std::vector<SkippedFrame>& skipped;
  long dropped_frames = 0;
  const std::vector<std::string>& output_errors;
  const StageTimes& times;
  const std::vector<int>& failed_frames;
  const std::vector<int>& recovered_frames;
  const std::vector<int>& refused_frames;
  const std::vector<int>& retracked_frames;
  const std::optional<CameraAccuracy>& accuracy;
  const std::vector<slam::ModelSnapshot>& snapshots;
  const std::vector<SurfelCloud>& all_models;  // empty when the device could not hand them back
  const std::vector<std::string>& events;
  const slam::SemanticParams& semantic;
  const std::string& semantic_source;
  const AsyncDetector* detector = nullptr;
};

nlohmann::ordered_json summary_json(const SummaryInputs& f) {
  nlohmann::ordered_json summary;
  summary["frames"] = f.frames;
  // false when a signal or an error ended the run before its input did (stop_reason says which);
  // the outputs then cover the frames processed.
  summary["complete"] = f.stop_reason.empty();
  if (!f.stop_reason.empty()) summary["stop_reason"] = f.stop_reason;
  summary["fps"] = f.frames / f.seconds;
  summary["device"] = f.device;
  summary["input"] = f.input;
  summary["skipped_frames"] = nlohmann::json::array();
  for (const auto& skipped : f.skipped)
    summary["skipped_frames"].push_back({{"frame", skipped.frame}, {"reason", skipped.reason}});
  summary["dropped_frames"] = f.dropped_frames;
  if (!f.output_errors.empty()) summary["output_errors"] = f.output_errors;
  for (const auto& stage : f.times.stages()) summary["stages_ms"][stage] = f.times.mean(stage);
  summary["tracking_failures"] = f.failed_frames;
  summary["camera"] = {{"lost_frames", f.failed_frames.size()}, {"recoveries", f.recovered_frames.size()},
                       {"recovered_at", f.recovered_frames}, {"refused_frames", f.refused_frames},
                       {"retracked_frames", f.retracked_frames}};
  if (f.accuracy) summary["camera"]["ate_rmse_m"] = f.accuracy->ate_rmse_m;
  summary["models"] = nlohmann::json::array();
  for (size_t k = 0; k < f.snapshots.size(); ++k) {
    const auto& m = f.snapshots[k];
    summary["models"].push_back({{"id", m.id},
                                 {"state", slam::to_string(m.state)},
                                 {"surfels", k < f.all_models.size() ? f.all_models[k].surfels.size() : 0},
                                 {"first_frame", m.first_frame},
                                 {"last_frame", m.last_frame},
                                 {"class", m.class_name}, {"class_confidence", m.class_confidence}});
  }
  summary["events"] = f.events;
  summary["semantic"] = {{"segmentation", slam::to_string(f.semantic.mode)},
                         {"source", f.semantic_source.empty() ? "none" : f.semantic_source},
                         {"exclude", f.semantic.exclude},
                         {"classes", f.semantic.classes}};
  if (f.detector)
    summary["semantic"]["detector"] = {{"detections", f.detector->detections_started()},
                                       {"frames_with_masks", f.detector->results_used()},
                                       {"mean_ms", f.detector->mean_detection_ms()}};
  return summary;
}

// The pipeline's parameters: the configuration's, with the command line's segmentation mode and
// class lists (checked here, before anything is opened).
slam::CoFusionParams pipeline_params(const RunOptions& o, const PipelineConfig& config) {
  slam::CoFusionParams params = config.cofusion();
  const auto mode = slam::parse_segmentation_mode(o.segmentation);
  if (!mode) throw Error("--segmentation must be motion, semantic or both, not '" + o.segmentation + "'");
  params.semantic.mode = *mode;
  params.semantic.exclude = split_list(o.exclude);
  params.semantic.classes = split_list(o.classes);
  for (const auto& c : params.semantic.exclude) require_class_name(c, "--exclude");
  for (const auto& c : params.semantic.classes) require_class_name(c, "--classes");
  if (!o.semantic_source.empty() && o.semantic_source != "masks" && o.semantic_source != "detector" &&
      o.semantic_source != "none")
    throw Error("--semantic-source must be masks, detector or none, not '" + o.semantic_source + "'");
  return params;
}


// segmentation/<timestamp>.png: the model id per pixel (0 = background, 65535 = no model: no depth
// or unassigned), named by the frame's timestamp (6 decimals, as in the trajectories), which is
// how TUM folders and generated scenes name their images and masks: `eval seg` pairs them by name.
void write_label_image(const fs::path& dir, const Frame& frame, std::vector<uint16_t>& labels) {
  const cv::Mat image(frame.depth_m.rows, frame.depth_m.cols, CV_16UC1, labels.data());
  char name[64];
  std::snprintf(name, sizeof name, "%.6f.png", frame.timestamp_s);
  write_atomically(dir / name, [&](const fs::path& tmp) {
    if (!cv::imwrite(tmp.string() + ".png", image)) throw Error("PNG encoding failed");
    fs::rename(tmp.string() + ".png", tmp);
  });
}

// The viewer's device extensions, or a clear error when no window can be opened.
gpu::ContextOptions context_options_for(const RunOptions& o) {
  gpu::ContextOptions options = o.gpu.context_options();
  if (o.headless) return options;
  try {
    renderer::Viewer::add_required_extensions(options);
  } catch (const std::exception& e) {
    throw Error(std::string("cannot open the viewer (") + e.what() + "); run with --headless");
  }
  return options;
}

std::unique_ptr<FrameSource> open_run_source(const RunOptions& o) {
  SourceOptions options;
  options.intrinsics = o.intrinsics;
  options.depth_correction = o.depth_correction;
  options.max_frames = o.max_frames;
  options.seed = o.seed;
  options.read_ahead_frames = SourceOptions::kRunReadAheadFrames;
  auto source = open_source(o.input, options);
  if (!source->intrinsics().plausible())
    throw Error("input " + o.input + ": implausible intrinsics " + source->intrinsics().to_string());
  return source;
}

// The output folder, after checking that the screenshot can be written.
fs::path checked_output_dir(const RunOptions& o) {
  if (!o.screenshot.empty()) {
    const fs::path parent = fs::path(o.screenshot).parent_path();
    ensure_writable_directory(parent.empty() ? fs::path(".") : parent);
  }
  return o.output;
}

std::vector<std::string> output_subfolders(const RunOptions& o) {
  return o.save_segmentation ? std::vector<std::string>{"trajectories", "segmentation"}
                             : std::vector<std::string>{"trajectories"};
}

// One `cofusion run`: its source, device, pipeline and viewer, and what it has gathered frame by
// frame; the frame loop, then every output for the frames processed (also after a stop or fault).
class RunSession {
 public:
  explicit RunSession(const RunOptions& o)
      : o_(o),
        config_(o.config_file.empty() ? PipelineConfig{} : load_config(o.config_file)),
        params_(pipeline_params(o, config_)),
        source_(open_run_source(o)),
        intrinsics_(source_->intrinsics()),
        out_dir_(checked_output_dir(o)),
        output_folder_(out_dir_, output_subfolders(o)),
        ctx_(context_options_for(o)),
        slam_(ctx_, intrinsics_, params_),
        // A camera: the detector never holds it up.
        masks_(o.semantic_source, config_.motion_segmentation, intrinsics_, o.input.rfind("openni2", 0) != 0,
               o.detector_every),
        gate_(*source_, intrinsics_, o.frame_gate),
        progress_(::isatty(STDOUT_FILENO)),
        total_frames_(source_->size()) {
    std::printf("device: %s\ninput: %s\n", ctx_.description().c_str(), source_->describe().c_str());
    if (!o.headless || !o.screenshot.empty()) view_renderer_ = std::make_unique<renderer::ViewRenderer>(ctx_);
    if (!o.headless) viewer_ = std::make_unique<renderer::Viewer>(ctx_);
  }

  // The exit status: 0, or 128 + the signal that stopped the run (its outputs written).
  int run() {
    start_ = std::chrono::steady_clock::now();
    try {
      while (!stop_requested() && viewer_allows_next_frame() && process_next_frame()) {
      }
    } catch (const std::exception& e) {
      if (frames_ == 0) throw;  // nothing to keep
      fault_ = std::current_exception();
      stop_reason_ = std::string("error: ") + e.what();
      progress_.message("error after " + std::to_string(frames_) + " frames: " + e.what() +
                            "\nwriting the outputs of those frames",
                        stderr);
    }
    progress_.finish();
    if (frames_ == 0 && !stop_reason_.empty()) throw Error(stop_reason_ + " before the first frame; nothing written");
    if (frames_ == 0) throw Error("input " + o_.input + " has no frames");
    if (!fault_ && ctx_.validation_error_count() > 0)
      throw Error(std::to_string(ctx_.validation_error_count()) + " Vulkan validation errors (see above)");
    write_outputs();
    if (fault_) std::rethrow_exception(fault_);
    // Stopped by a signal: the shell's convention for it, 128 + the signal number.
    return stop_signals_.requested() ? 128 + stop_signals_.requested() : 0;
  }

 private:
  double elapsed_s() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

  bool stop_requested() {
    const int signal = stop_signals_.requested();
    if (!signal) return false;
    stop_reason_ = StopSignals::name(signal);
    progress_.message(stop_reason_ + ": stopping after " + std::to_string(frames_) +
                      " frames; writing their outputs (a second " + stop_reason_ + " ends at once)");
    return true;
  }

  // Space pauses, N runs one frame, Q quits; the window stays live while paused.
  bool viewer_allows_next_frame() {
    if (!viewer_) return true;
    while (viewer_->state().paused && !viewer_->state().step_requested && !viewer_->state().quit_requested &&
           viewer_->poll())
      show();
    if (viewer_->state().quit_requested || !viewer_->poll()) return false;
    viewer_->state().step_requested = false;
    return true;
  }

  // Reads, processes and records the next frame; false at the end of the input.
  bool process_next_frame() {
    std::optional<Frame> frame;
    {
      ScopedStage s(times_, "read");
      frame = gate_.next();
    }
    if (!frame) return false;
    if (gate_.skipped().size() > skipped_before_ && !timestamps_.empty() &&
        frame->timestamp_s - timestamps_.back() > o_.frame_gate.relocalise_after_gap_s)
      slam_.note_gap();  // a long gap: relocalise across it
    skipped_before_ = gate_.skipped().size();
    slam_.note_frame_time(frame->timestamp_s, frame->colour_readout_s);
    const cv::Mat depth = frame->depth_m.isContinuous() ? frame->depth_m : frame->depth_m.clone();
    const cv::Mat rgb = frame->rgb.isContinuous() ? frame->rgb : frame->rgb.clone();
    slam::CoFusionFrame r = slam_.process(depth.ptr<float>(), rgb.data, masks_.for_frame(*frame, rgb, depth));
    record(*frame, r);
    return true;
  }

  void record(const Frame& frame, slam::CoFusionFrame& r) {
    for (const auto& [stage, ms] : r.stage_ms) times_.add(stage, ms);
    if (r.frame > 0 && config_.motion_segmentation) {
      times_.add("superpixels (CPU)", r.superpixels_ms);
      times_.add("superpixels overlapped with GPU", r.superpixels_overlap_ms);
    }
    camera_.push_back({frame.timestamp_s, r.T_world_camera});
    if (frame.T_world_camera_gt) groundtruth_.push_back({frame.timestamp_s, *frame.T_world_camera_gt});
    timestamps_.push_back(frame.timestamp_s);
    ++frames_;  // processed: its pose is in the trajectory
    output_folder_.keep();  // from the first processed frame on, the run has output to write
    T_world_camera_last_ = r.T_world_camera;
    if (r.camera_state == slam::CameraState::kLost) {
      failed_frames_.push_back(frame.index);
      progress_.message("frame " + std::to_string(frame.index) + ": camera lost (" +
                        r.camera_tracking.failure_reason + "); pose not updated, frame not fused");
    } else if (r.camera_state == slam::CameraState::kRecovered) {
      recovered_frames_.push_back(frame.index);
    } else if (r.camera_state == slam::CameraState::kRefused) {
      refused_frames_.push_back(frame.index);
    }
    if (r.camera_retracked) retracked_frames_.push_back(frame.index);
    for (const auto& e : r.events) {
      progress_.message(e);
      events_.push_back(e);
    }
    if (o_.save_segmentation) write_label_image(out_dir_ / "segmentation", frame, r.labels);
    report_progress(frame, r);
  }

  void report_progress(const Frame& frame, slam::CoFusionFrame& r) {
    unsigned surfels = 0;
    for (const auto& m : r.active) surfels += m.surfels;
    const double elapsed = elapsed_s();
    progress_.update({.processed = frames_,
                      .read = frame.index + 1,
                      .total = total_frames_,
                      .fps = frames_ / elapsed,
                      .models = r.active.size(),
                      .surfels = surfels,
                      .inlier_ratio = r.camera_tracking.inlier_ratio,
                      .camera_state = slam::to_string(r.camera_state)});
    if (viewer_ || !o_.screenshot.empty()) {
      last_frame_ = frame;
      last_labels_ = std::move(r.labels);
    }
    if (viewer_) {
      char line[160];
      std::snprintf(line, sizeof line, "frame %d  %.1f fps  models %zu  surfels %u  camera %s", frames_,
                    frames_ / elapsed, r.active.size(), surfels, slam::to_string(r.camera_state));
      status_ = line;
      show();
    }
  }

  renderer::Overlay make_overlay(const std::vector<std::string>& text) const {
    renderer::Overlay overlay;
    if (last_frame_) overlay.insets = live_insets(*last_frame_, last_labels_);
    for (const auto& p : camera_) overlay.trajectory_world.push_back(p.T_world_x.translation());
    overlay.T_world_camera = T_world_camera_last_;
    overlay.camera_intrinsics = intrinsics_;
    overlay.text_lines = text;
    return overlay;
  }

  // Active models are drawn; inactive ones are out of view by definition.
  std::vector<renderer::ModelView> model_views() const {
    std::vector<renderer::ModelView> views;
    for (const auto& m : slam_.models())
      if (m.state == slam::ModelState::kActive)
        views.push_back({m.model->surfels(), m.model->count(), m.id, m.model->T_world_model});
    return views;
  }

  std::vector<SurfelCloud> clouds(bool active_only) {
    std::vector<SurfelCloud> out;
    for (const auto& m : slam_.models()) {
      if (active_only && m.state != slam::ModelState::kActive) continue;
      SurfelCloud cloud;
      cloud.model_id = m.id;
      cloud.class_name = m.class_name;
      cloud.T_world_model = m.model->T_world_model;
      cloud.surfels = m.model->download(slam_.stream());
      out.push_back(std::move(cloud));
    }
    return out;
  }

  static std::vector<renderer::ModelBox> boxes(const std::vector<SurfelCloud>& models) {
    std::vector<renderer::ModelBox> out;
    for (const auto& cloud : models) {
      if (cloud.surfels.empty()) continue;
      out.push_back(renderer::bounding_box(cloud));
      out.back().label = renderer::model_label(cloud.model_id, cloud.class_name);
    }
    return out;
  }

  void show() {
    const auto views = model_views();
    renderer::Overlay overlay = make_overlay({});
    // The boxes need the surfel centres on the host: a read-back of the models (a few ms).
    overlay.boxes = boxes(clouds(true));
    viewer_->frame(slam_.stream(), *view_renderer_, views, overlay, status_);
  }

  // After a fault each output is attempted on its own (the device may be lost, the disk full):
  // what can be written is, and the failures are listed in summary.json.
  template <typename Write>
  void attempt(const char* what, const Write& write) {
    if (!fault_) return write();
    try {
      write();
    } catch (const std::exception& e) {
      output_errors_.push_back(std::string(what) + ": " + e.what());
      std::fprintf(stderr, "cannot write %s: %s\n", what, e.what());
    }
  }

  void write_model_trajectories(const std::vector<slam::ModelSnapshot>& snapshots) {
    for (const auto& m : snapshots) {
      if (m.id == 0) continue;
      Trajectory trajectory;
      for (const auto& [frame_index, T_world_model] : m.trajectory)
        trajectory.push_back({timestamps_.at(static_cast<size_t>(frame_index)), T_world_model});
      write_tum_trajectory(out_dir_ / "trajectories" / ("model-" + std::to_string(m.id) + ".txt"), trajectory);
    }
  }

  void write_screenshot(size_t total_surfels) {
    const auto views = model_views();
    const renderer::VirtualCamera view =
        viewer_ ? viewer_->camera(T_world_camera_last_) : overview_camera(intrinsics_, T_world_camera_last_);
    renderer::Image image = view_renderer_->render(slam_.stream(), views, view, renderer::RenderParams{});
    char line[160];
    std::snprintf(line, sizeof line, "frame %d  models %zu  surfels %zu", frames_, views.size(), total_surfels);
    renderer::Overlay overlay = make_overlay({line});
    overlay.boxes = boxes(clouds(true));
    renderer::draw_overlay(image, view, overlay);
    const std::vector<uint8_t> png = renderer::encode_png(image);
    write_bytes_atomically(o_.screenshot, std::as_bytes(std::span(png)));
  }

  void write_outputs() {
    const double seconds = elapsed_s();
    attempt("trajectories/camera.txt", [&] { write_tum_trajectory(out_dir_ / "trajectories" / "camera.txt", camera_); });
    const std::vector<slam::ModelSnapshot> snapshots = slam_.models();
    bool model_trajectories_written = false;
    attempt("the model trajectories", [&] {
      write_model_trajectories(snapshots);
      model_trajectories_written = true;
    });
    if (o_.save_segmentation)
      attempt("segmentation/classes.txt",
              [&] { write_segmentation_classes(out_dir_ / "segmentation" / kInstanceClassesFile, snapshots); });
    std::vector<SurfelCloud> all_models;  // stays empty when the device cannot hand the models back
    std::vector<fs::path> model_files;
    attempt("the models", [&] {
      all_models = clouds(false);
      model_files = write_models(all_models, camera_, out_dir_);
    });
    const std::optional<CameraAccuracy> accuracy = camera_accuracy(groundtruth_, camera_);
    size_t total_surfels = 0;
    for (const auto& cloud : all_models) total_surfels += cloud.surfels.size();
    if (!o_.screenshot.empty()) attempt("the screenshot", [&] { write_screenshot(total_surfels); });

    SummaryInputs facts{frames_, stop_reason_, seconds, ctx_.description(), source_->describe(), gate_.skipped(),
                        source_->dropped_frames(), output_errors_, times_, failed_frames_, recovered_frames_, refused_frames_, retracked_frames_, accuracy,
                        snapshots, all_models, events_, params_.semantic, masks_.source(), masks_.detector()};
    write_text_atomically(out_dir_ / "summary.json", summary_json(facts).dump(2) + "\n");
    std::printf("%d frames in %.2f s (%.1f fps), %zu models, %zu surfels, %zu tracking failures, %zu frames skipped; "
                "wrote %s%s\n",
                frames_, seconds, frames_ / seconds, snapshots.size(), total_surfels, failed_frames_.size(),
                gate_.skipped().size(), out_dir_.c_str(), stop_reason_.empty() ? "" : " (incomplete)");
    const auto rows = model_rows(snapshots, all_models, model_files, out_dir_, model_trajectories_written);
    std::printf("%s%s", model_table(rows).c_str(), report_footer(out_dir_, accuracy).c_str());
  }

  const RunOptions& o_;
  const PipelineConfig config_;
  const slam::CoFusionParams params_;
  std::unique_ptr<FrameSource> source_;
  const Intrinsics intrinsics_;
  const fs::path out_dir_;
  OutputFolder output_folder_;  // taken away again unless a frame is processed: a failed start leaves nothing
  gpu::Context ctx_;
  std::unique_ptr<renderer::ViewRenderer> view_renderer_;
  std::unique_ptr<renderer::Viewer> viewer_;
  slam::CoFusion slam_;
  FrameMasks masks_;  // where the instance masks come from, decided at the first frame
  FrameGate gate_;
  const StopSignals stop_signals_;
  ProgressPrinter progress_;
  const std::optional<int> total_frames_;

  std::chrono::steady_clock::time_point start_;
  StageTimes times_;
  Trajectory camera_;
  Trajectory groundtruth_;  // the input's camera poses of the processed frames, where it has them
  std::vector<double> timestamps_;  // per processed frame, for the model trajectories
  std::vector<int> failed_frames_;     // lost: camera tracking failed or not yet relocalised
  std::vector<int> recovered_frames_;  // relocalised after a loss
  std::vector<int> refused_frames_;    // the tracked camera motion was refused (CameraCheckParams)
  std::vector<int> retracked_frames_;  // tracked again after the segmentation (CameraRetrackParams)
  std::vector<std::string> events_;
  std::vector<std::string> output_errors_;
  size_t skipped_before_ = 0;  // gate_.skipped() at the previous frame
  std::string stop_reason_;  // why the run ended before its input did; empty when it did not
  std::exception_ptr fault_;  // the error that ended the run after its first frame
  int frames_ = 0;
  Pose T_world_camera_last_ = Pose::Identity();
  std::optional<Frame> last_frame_;  // shares the pixels; insets are made only when drawn
  std::vector<uint16_t> last_labels_;
  std::string status_;
};

int run(const RunOptions& o) {
  if (handle_list_devices(o.gpu)) return 0;
  RunSession session(o);
  return session.run();
}

// --max-frames: a whole number >= 1, said in one line (CLI11's PositiveNumber prints its range
// with a 300-digit maximum).
CLI::Validator frame_count_check() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        int n = 0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
        if (ec != std::errc() || end != text.data() + text.size() || n < 1)
          return "must be a whole number of frames, 1 or more (got '" + text + "')";
        return "";
      },
      "N>=1");
}

}  // namespace

void add_run(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  auto* cmd = app.add_subcommand("run", "Run the pipeline on an input (default: the built-in synthetic scene)");
  cmd->add_option("--input", o->input,
                  "SOURCE: synthetic[:SCENE] (default), tum:PATH, klg:PATH, oni:PATH, openni2[:URI], images:PATH");
  cmd->add_option("--output", o->output, "Output folder (default ./cofusion-out)");
  cmd->add_flag("--headless", o->headless, "Run without a window (the viewer needs a display)");
  cmd->add_option("--screenshot", o->screenshot, "Write the final view as PNG (from the window, or offscreen)");
  cmd->add_option("--max-frames", o->max_frames, "Stop after N frames (bad frames count)")->check(frame_count_check());
  cmd->add_flag("--strict", o->frame_gate.strict,
                "Fail at the first bad frame (default: skip it with a warning; summary.json lists it)");
  cmd->add_option("--config", o->config_file, "JSON file of pipeline parameters")->check(CLI::ExistingFile);
  cmd->add_flag("--save-segmentation", o->save_segmentation, "Write per-frame label images to segmentation/");
  cmd->add_option("--intrinsics", o->intrinsics, "fx,fy,cx,cy | calibration file | preset (fr1, fr2, fr3, primesense)");
  cmd->add_option("--depth-correction", o->depth_correction,
                  "Recorded depth / DS = metric depth (default: TUM folders of the fr1/fr2 cameras 1.035/1.031, as the TUM benchmark lists; else 1)")
      ->check(CLI::Range(0.5, 2.0));
  cmd->add_option("--seed", o->seed, "Synthetic scenes: noise seed (0 = the scene's own)");
  cmd->add_option("--segmentation", o->segmentation,
                  "motion (default: models from motion; masks only exclude classes and name models), semantic (models "
                  "from recognised instances, motion spawns none) or both");
  cmd->add_option("--semantic-source", o->semantic_source,
                  "Instance masks: masks (the input's), detector (built-in, asynchronous: a detection made from a frame "
                  "is used for the next one), none (default: masks when the input has them, else the detector when its "
                  "models are there)");
  cmd->add_option("--exclude", o->exclude,
                  "Comma-separated classes whose pixels are never modelled, fused or tracked with (default person; "
                  "\"\" = none)");
  cmd->add_option("--detector-every", o->detector_every,
                  "Start a detection on every Nth frame only (default 1; the frames between get the last detection's masks, carried by the camera's motion)")
      ->check(CLI::Range(1, 1000));
  cmd->add_option("--classes", o->classes, "Comma-separated classes that become models in semantic/both modes (default all)");
  o->gpu.add_to(*cmd);
  cmd->callback([o] {
    // CLI11 turns RuntimeError into the exit status without printing anything.
    if (const int status = run(*o)) throw CLI::RuntimeError(status);
  });
}

}  // namespace cofusion::commands
