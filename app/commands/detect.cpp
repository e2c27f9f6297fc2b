// `cofusion detect`: the built-in semantic detector on a frame source, written as instance masks
// in a TUM folder's masks/ layout (DIR/masks/<stem>.png, 16-bit ids, DIR/masks/classes.txt with
// "id class_name" lines), with the time per forward pass.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "commands/commands.h"
#include "commands/sources.h"
#include "common/error.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/tum_source.h"
#include "semantic/detector.h"
#include "semantic/instance_masks.h"

namespace cofusion::commands {
namespace {
namespace fs = std::filesystem;

struct DetectOptions {
  std::string input;
  std::string output;
  std::string models;
  std::string intrinsics;
  std::optional<double> depth_correction;
  std::optional<int> max_frames;
  float score_threshold = semantic::DetectorParams{}.score_threshold;
  bool no_person_segmenter = false;
  bool overlay = false;
};

// build/models beside build/app/cofusion: the folder .ci/fetch-models.sh fills by default.
fs::path default_models_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return semantic::models_dir(ec ? fs::path("build/models") : exe.parent_path().parent_path() / "models");
}

// Timestamp -> colour file stem of a TUM folder's rgb.txt, so masks are named like the colour
// images (rgb/x.jpg -> masks/x.png); other sources name them by the timestamp with 6 decimals.
std::map<double, std::string> tum_stems(const std::string& spec) {
  std::string path = spec.rfind("tum:", 0) == 0 ? spec.substr(4) : spec;
  std::map<double, std::string> stems;
  std::error_code ec;
  if (!fs::is_regular_file(fs::path(path) / "rgb.txt", ec)) return stems;
  for (const TimedFile& f : read_tum_file_list(fs::path(path) / "rgb.txt"))
    stems[f.timestamp_s] = fs::path(f.file).stem().string();
  return stems;
}

cv::Mat overlay_image(const Frame& frame, const semantic::InstanceMasks& masks) {
  cv::Mat out = frame.rgb.clone();
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x)
      if (const uint16_t id = masks.ids.at<uint16_t>(y, x); id != 0) {
        // Saturated colours whose hues step by the golden angle, so neighbouring ids differ.
        const float hue = std::fmod(static_cast<float>(id) * 137.5f, 360.f) / 60.f;
        const float f = hue - std::floor(hue);
        const auto v = [](float t) { return static_cast<uint8_t>(255.f * t); };
        const cv::Vec3b palette[6] = {{255, v(f), 0}, {v(1 - f), 255, 0}, {0, 255, v(f)},
                                      {0, v(1 - f), 255}, {v(f), 0, 255}, {255, 0, v(1 - f)}};
        const cv::Vec3b c = palette[static_cast<int>(hue) % 6];
        out.at<cv::Vec3b>(y, x) = out.at<cv::Vec3b>(y, x) / 2 + c / 2;
      }
  for (const auto& inst : masks.instances) {
    cv::rectangle(out, cv::Rect(inst.box_px), cv::Scalar(255, 0, 0), 1);
    char label[96];
    std::snprintf(label, sizeof label, "%d %s %.2f", inst.id, inst.class_name.c_str(), inst.score);
    cv::putText(out, label, cv::Point(static_cast<int>(inst.box_px.x) + 2, static_cast<int>(inst.box_px.y) + 12),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 0), 1);
  }
  return out;
}

void detect(const DetectOptions& o) {
  const fs::path models = o.models.empty() ? default_models_dir() : fs::path(o.models);
  semantic::DetectorParams params;
  params.score_threshold = o.score_threshold;
  semantic::Detector detector(models / "centernet.pb", params);
  std::optional<semantic::PersonSegmenter> segmenter;
  if (!o.no_person_segmenter) segmenter.emplace(models / "selfie.pb");

  const fs::path out_dir(o.output);
  ensure_writable_directory(out_dir / "masks");
  if (o.overlay) ensure_writable_directory(out_dir / "overlay");
  SourceOptions source_options;
  source_options.intrinsics = o.intrinsics;
  source_options.depth_correction = o.depth_correction;
  source_options.max_frames = o.max_frames;
  auto source = open_source(o.input, source_options);
  std::printf("input: %s\nmodels: %s\n", source->describe().c_str(), models.string().c_str());
  std::fflush(stdout);
  const auto stems = tum_stems(o.input);

  // Ids are unique over the whole sequence (classes.txt holds one class per id for every frame):
  // each frame's instances take the next free ids; nothing associates them between frames.
  std::string classes = "# cofusion detect: instance id -> COCO class (one id per instance per frame)\n";
  int frames = 0, next_id = 1, instances = 0;
  double detector_ms = 0, segmenter_ms = 0, masks_ms = 0;
  while (auto frame = source->next()) {
    const auto dets = detector.detect(frame->rgb);
    detector_ms += detector.last_forward_ms();
    cv::Mat person;
    if (segmenter) {
      person = segmenter->segment(frame->rgb);
      segmenter_ms += segmenter->last_forward_ms();
    }
    const auto t0 = std::chrono::steady_clock::now();
    semantic::InstanceMasks masks = semantic::instance_masks(dets, frame->depth_m, frame->intrinsics, {}, person);
    masks_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (next_id + static_cast<int>(masks.instances.size()) > 65535)
      throw Error("frame " + std::to_string(frame->index) + ": more than 65535 instances in the sequence");
    cv::Mat ids = masks.ids.clone();
    for (int y = 0; y < ids.rows; ++y)
      for (int x = 0; x < ids.cols; ++x)
        if (uint16_t& id = ids.at<uint16_t>(y, x); id != 0) id = static_cast<uint16_t>(id - 1 + next_id);
    for (auto& inst : masks.instances) {
      inst.id = static_cast<uint16_t>(inst.id - 1 + next_id);
      classes += std::to_string(inst.id) + " " + inst.class_name + "\n";
    }
    masks.ids = ids;
    next_id += static_cast<int>(masks.instances.size());
    instances += static_cast<int>(masks.instances.size());

    std::string stem;
    if (const auto it = stems.find(frame->timestamp_s); it != stems.end()) {
      stem = it->second;
    } else {
      char stamp[64];
      std::snprintf(stamp, sizeof stamp, "%.6f", frame->timestamp_s);
      stem = stamp;
    }
    write_u16_png(out_dir / "masks" / (stem + ".png"), masks.ids);
    if (o.overlay) write_rgb_image(out_dir / "overlay" / (stem + ".png"), overlay_image(*frame, masks));
    ++frames;
  }
  write_text_atomically(out_dir / "masks" / "classes.txt", classes);
  const double n = std::max(frames, 1);
  std::printf("detected %d instances in %d frames -> %s\n", instances, frames, (out_dir / "masks").string().c_str());
  std::printf("per frame: detector forward pass %.0f ms, person segmenter %.0f ms, masks %.1f ms\n",
              detector_ms / n, segmenter_ms / n, masks_ms / n);
}

}  // namespace

void add_detect(CLI::App& app) {
  auto o = std::make_shared<DetectOptions>();
  auto* cmd = app.add_subcommand(
      "detect", "Instance masks from the built-in COCO detector (CenterNet) and depth, in a TUM folder's masks/ layout");
  cmd->add_option("--input,-i", o->input,
                  "Source: synthetic[:SCENE], tum:PATH, klg:PATH, oni:PATH, openni2[:URI], images:PATH")
      ->required();
  cmd->add_option("--output,-o", o->output, "Output folder: masks/<stem>.png and masks/classes.txt")->required();
  cmd->add_option("--max-frames", o->max_frames, "Process at most this many frames")->check(CLI::NonNegativeNumber);
  cmd->add_option("--models", o->models,
                  "Folder with centernet.pb and selfie.pb (default: $COFUSION_MODELS, else build/models beside the executable; .ci/fetch-models.sh fills it)");
  cmd->add_option("--score-threshold", o->score_threshold, "Detector heatmap threshold (class probability)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_flag("--no-person-segmenter", o->no_person_segmenter,
                "People's masks from depth like other objects instead of the selfie segmenter");
  cmd->add_flag("--overlay", o->overlay, "Also write overlay/<stem>.png: masks and boxes over the colour image");
  cmd->add_option("--intrinsics", o->intrinsics, "fx,fy,cx,cy[,w,h] | calibration file | preset (fr1, fr2, fr3, primesense)");
  cmd->add_option("--depth-correction", o->depth_correction, "Recorded depth / DS = metric depth")
      ->check(CLI::Range(0.5, 2.0));
  cmd->callback([o] { detect(*o); });
}

}  // namespace cofusion::commands
