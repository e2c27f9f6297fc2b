#pragma once
// CPU ray caster for the analytic synthetic world: one ray per pixel centre (no anti-aliasing),
// rows in parallel (oneTBB), then the Kinect-like noise model (noise.h) on the depth.
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "common/intrinsics.h"
#include "io/frame.h"
#include "synthetic/geometry.h"
#include "synthetic/noise.h"
#include "synthetic/scene.h"

namespace cofusion::synthetic {

struct RenderedFrame {
  cv::Mat rgb;           // CV_8UC3 R,G,B: Lambert + ambient shaded texture, plus colour noise
  cv::Mat depth_m;       // CV_32FC1 metres with sensor noise and holes (0 = no reading)
  cv::Mat depth_true_m;  // CV_32FC1 metres, exact camera-frame z of the visible surface (0 = nothing hit)
  cv::Mat instance_ids;  // CV_16UC1 0 = static background (room, table, static parts), k = objects[k - 1] (all its parts)
  cv::Mat cos_incidence;  // CV_32FC1 |cos| of the angle between the pixel's ray and the surface normal
  // Only when RenderRequest::surface_points: CV_32FC3, (0,0,0) where nothing is hit.
  cv::Mat points_world;   // visible surface point, world frame
  cv::Mat points_object;  // the same point in its owner's frame: object k's frame, or world for background
};
// A covered lens (RenderRequest::covered) gives depth 0 everywhere (true and noisy), instance id 0,
// cos_incidence 0, zero surface points and a nearly black colour image with twice the sensor's
// colour noise (none when KinectNoiseParams::color_sigma is 0).

struct RenderRequest {
  int frame_index = 0;  // with `seed`, selects the noise pattern
  Pose T_world_camera = Pose::Identity();
  std::vector<std::optional<Pose>> T_world_objects;  // per object (index k - 1); nullopt = absent
  // Per object, T_object_part of each of its parts (Renderer::object_parts()[k - 1] order); an empty
  // list (or none at all) leaves every part at the object origin, which is right for rigid objects.
  std::vector<std::vector<Pose>> T_object_parts;
  bool covered = false;  // the lens is covered this frame (see RenderedFrame)
  KinectNoiseParams noise = KinectNoiseParams::none();
  unsigned seed = 1;
  bool surface_points = false;
};

// Holds the scene's static parts and shading parameters; render() is const and thread-safe.
class Renderer {
 public:
  explicit Renderer(const SceneDescription& scene);

  RenderedFrame render(const RenderRequest& request) const;

  const Intrinsics& intrinsics() const { return intrinsics_; }
  const std::vector<Primitive>& background() const { return background_; }
  // object_parts()[k - 1]: the parts of object k (instance id k), each in its own frame.
  const std::vector<std::vector<Primitive>>& object_parts() const { return object_parts_; }

 private:
  RenderedFrame render_covered(const RenderRequest& request) const;

  Intrinsics intrinsics_;
  LightDesc light_;
  std::vector<Primitive> background_;
  std::vector<std::vector<Primitive>> object_parts_;
  std::vector<float> normal_table_;  // equiprobable standard-normal levels for the axial noise
};

}  // namespace cofusion::synthetic
