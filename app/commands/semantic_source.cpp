#include "commands/semantic_source.h"

#include <chrono>
#include <cstdio>

#include "common/error.h"

namespace cofusion::commands {

namespace {
// A live camera's frames do not wait for the detector: a result may finish a few processed frames
// after its frame; it is used for this many frames more than on a recording.
constexpr int kLiveExtraAgeFrames = 2;
}  // namespace

std::filesystem::path default_models_dir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return semantic::models_dir(ec ? std::filesystem::path("build/models") : exe.parent_path().parent_path() / "models");
}

std::optional<slam::SemanticFrame> semantic_frame_from_masks(const Frame& frame) {
  if (frame.mask.empty()) return std::nullopt;
  if (frame.mask.type() != CV_16UC1 || frame.mask.cols != frame.depth_m.cols || frame.mask.rows != frame.depth_m.rows)
    throw Error("frame " + std::to_string(frame.index) + ": its mask is not a 16-bit image of the depth's size");
  slam::SemanticFrame s;
  const cv::Mat mask = frame.mask.isContinuous() ? frame.mask : frame.mask.clone();
  s.ids.assign(mask.ptr<uint16_t>(), mask.ptr<uint16_t>() + mask.total());
  if (frame.mask_classes) s.classes = frame.mask_classes->name_by_id;
  return s;
}

AsyncDetector::AsyncDetector(const std::filesystem::path& models, const Intrinsics& intrinsics, bool wait_for_result,
                             int every_frames, int max_age_frames)
    : detector_(models / "centernet.pb"),
      segmenter_(models / "selfie.pb"),
      intrinsics_(intrinsics),
      wait_for_result_(wait_for_result),
      every_frames_(every_frames),
      max_age_frames_(max_age_frames) {
  if (every_frames < 1) throw Error("the detector's frame interval must be >= 1, not " + std::to_string(every_frames));
}

AsyncDetector::~AsyncDetector() { jobs_.wait(); }

bool AsyncDetector::submit(int frame_index, const cv::Mat& rgb, const cv::Mat& depth_m) {
  if (every_frames_ > 1 && frame_index % every_frames_ != 0) return false;
  if (running_.load(std::memory_order_acquire)) return false;
  jobs_.wait();  // the finished task's group (returns at once)
  running_.store(true, std::memory_order_release);
  ++started_;
  jobs_.run([this, frame_index, call = calls_, rgb = rgb.clone(), depth = depth_m.clone()] {
    const auto start = std::chrono::steady_clock::now();
    slam::SemanticFrame s;
    try {
      const auto detections = detector_.detect(rgb);
      const cv::Mat person = segmenter_.segment(rgb);
      const semantic::InstanceMasks masks = semantic::instance_masks(detections, depth, intrinsics_, {}, person);
      s.ids.assign(masks.ids.ptr<uint16_t>(), masks.ids.ptr<uint16_t>() + masks.ids.total());
      for (const auto& inst : masks.instances) s.classes[inst.id] = inst.class_name;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "frame %d: detection failed: %s\n", frame_index, e.what());
      s = {};
    }
    total_ms_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    ++finished_;
    if (!s.ids.empty()) {
      result_ = std::move(s);
      result_call_ = call;
    }
    running_.store(false, std::memory_order_release);
  });
  return true;
}

const slam::SemanticFrame* AsyncDetector::for_frame() {
  ++calls_;
  if (wait_for_result_) jobs_.wait();
  if (!running_.load(std::memory_order_acquire) && result_call_ > current_call_) {
    current_ = result_;
    current_call_ = result_call_;
    current_handed_out_ = false;
  }
  if (current_call_ < 0) return nullptr;
  current_.age_frames = calls_ - current_call_;
  if (current_.age_frames < 1 || current_.age_frames > max_age_frames_) return nullptr;
  current_.repeated = current_handed_out_;
  current_handed_out_ = true;
  ++used_;
  return &current_;
}

std::string choose_semantic_source(const Frame& first, bool motion_segmentation) {
  std::string source;
  if (!first.mask.empty()) {
    source = "masks";
  } else if (std::error_code ec; std::filesystem::is_regular_file(default_models_dir() / "centernet.pb", ec)) {
    source = "detector";
  } else {
    std::printf("no instance masks: the input has none and the detector's models are not in %s (run "
                ".ci/fetch-models.sh or set COFUSION_MODELS); no class is excluded\n",
                default_models_dir().c_str());
    return "none";
  }
  if (!motion_segmentation) {
    std::printf("instance masks are not used: they need motion segmentation (off in the configuration)\n");
    return "none";
  }
  std::printf("instance masks: %s\n", source.c_str());
  return source;
}

FrameMasks::FrameMasks(std::string source, bool motion_segmentation, const Intrinsics& intrinsics,
                       bool wait_for_detections, int detector_every)
    : source_(std::move(source)), motion_segmentation_(motion_segmentation), intrinsics_(intrinsics),
      wait_for_detections_(wait_for_detections), detector_every_(detector_every) {}

const slam::SemanticFrame* FrameMasks::for_frame(const Frame& frame, const cv::Mat& rgb, const cv::Mat& depth_m) {
  if (source_.empty()) source_ = choose_semantic_source(frame, motion_segmentation_);
  if (source_ == "masks") {
    if (frame.mask.empty())
      throw Error("frame " + std::to_string(frame.index) + " has no instance mask (--semantic-source masks)");
    masks_ = semantic_frame_from_masks(frame);
    return masks_ ? &*masks_ : nullptr;
  }
  if (source_ != "detector") return nullptr;
  if (!detector_)
    detector_ = std::make_unique<AsyncDetector>(default_models_dir(), intrinsics_, wait_for_detections_, detector_every_,
                                                detector_every_ + (wait_for_detections_ ? 0 : kLiveExtraAgeFrames));
  const slam::SemanticFrame* previous = detector_->for_frame();
  detector_->submit(frame.index, rgb, depth_m);
  return previous;
}

}  // namespace cofusion::commands
