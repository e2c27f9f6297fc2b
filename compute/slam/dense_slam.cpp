#include "slam/dense_slam.h"

#include <chrono>

#include "common/se3.h"

namespace cofusion::slam {
namespace {
class Stopwatch {
 public:
  double lap_ms() {
    const auto now = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - last_).count();
    last_ = now;
    return ms;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};
}  // namespace

DenseSlam::DenseSlam(gpu::Context& ctx, const Intrinsics& intrinsics, const SlamParams& params, uint32_t worker)
    : ctx_(ctx),
      params_(params),
      stream_(ctx, worker, "slam"),
      preprocessor_(ctx),
      surfels_(ctx, preprocessor_),
      tracker_(ctx, params.tracker),
      live_(kernels::FramePyramid::allocate(ctx, intrinsics, params.preprocess.pyramid_levels, "live")),
      prediction_(ModelPrediction::allocate(ctx, intrinsics, params.preprocess.pyramid_levels, "prediction")),
      model_(ctx, 0, params.fusion.initial_capacity),
      unwarper_(params.rolling_shutter) {
  if (int(params.tracker.iterations_per_level.size()) < params.preprocess.pyramid_levels)
    throw Error("tracker needs iterations for each of the " + std::to_string(params.preprocess.pyramid_levels) +
                " pyramid levels");
}

FrameResult DenseSlam::process(const float* depth_m, const uint8_t* input_rgb) {
  FrameResult r;
  r.frame = frame_;
  Stopwatch clock;
  // A frame whose tracking failed leaves no motion to go by (last_motion_ is then no motion).
  const uint8_t* rgb = unwarper_.unwarp(input_rgb, live_.levels[0].intrinsics, last_motion_, frame_ > 0);
  if (rgb != input_rgb) r.stage_ms.emplace_back("rolling shutter", clock.lap_ms());
  live_.upload(stream_, depth_m, rgb);
  r.stage_ms.emplace_back("upload", clock.lap_ms());
  stream_.run([&](gpu::CommandList& c) {
    preprocessor_.record_frame(c, live_, kernels::FramePyramid::kUploadMetresPerUnit, params_.effective_preprocess());
  });
  r.stage_ms.emplace_back("preprocess", clock.lap_ms());

  if (model_.count() > 0) {
    // Prediction: stable surfels, plus unstable ones still inside their confirmation window.
    PredictionParams prediction;
    prediction.min_confidence = params_.fusion.stable_confidence;
    prediction.recent_window_frames = params_.prediction_recent_window_frames;
    const Eigen::Isometry3d T_camera_model = T_world_camera_.inverse() * model_.T_world_model;
    stream_.run([&](gpu::CommandList& c) { surfels_.predict(c, model_, T_camera_model, prediction_, prediction, frame_); });
    r.stage_ms.emplace_back("predict", clock.lap_ms());

    const Eigen::Isometry3d guess = params_.constant_velocity_guess ? last_motion_ : Eigen::Isometry3d::Identity();
    r.tracking = tracker_.track(stream_, live_.levels, prediction_.levels, guess);
    r.tracked = true;
    r.stage_ms.emplace_back("track", clock.lap_ms());
    const Eigen::Isometry3d motion = r.tracking.failed ? guess : r.tracking.T_reference_live;
    T_world_camera_ = orthonormalised(T_world_camera_ * motion);
    last_motion_ = r.tracking.failed ? Eigen::Isometry3d::Identity() : motion;
  }
  r.T_world_camera = T_world_camera_;
  // A frame whose tracking failed is not fused: its pose is a guess and would corrupt the map.
  if (!r.tracking.failed) {
    r.fusion = surfels_.fuse(stream_, model_, live_, T_world_camera_.inverse() * model_.T_world_model, frame_,
                             params_.fusion, nullptr, 0, std::nullopt, float(r.tracking.live_intensity_gain));
  }
  r.stage_ms.emplace_back("fuse", clock.lap_ms());
  ++frame_;
  return r;
}

}  // namespace cofusion::slam
