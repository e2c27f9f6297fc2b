#pragma once
// Synthetic dynamic scenes with ground truth: the default input of `cofusion run`, and the data
// behind `cofusion generate`. A scene (scene.h) is rendered frame by frame on the CPU
// (renderer.h); every frame is independent of the others, so frames may be rendered in any order
// and in parallel.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "io/frame.h"
#include "io/trajectory.h"
#include "synthetic/geometry.h"
#include "synthetic/renderer.h"
#include "synthetic/scene.h"

namespace cofusion::synthetic {

struct ObjectInfo {
  int id = 0;  // instance id in masks (1-based)
  std::string name;
  std::string class_name;
  ObjectKind kind = ObjectKind::kRigid;
  Shape shape = Shape::kBox;  // rigid objects
  // Present in [first_frame, last_frame], clipped to the sequence (first > last: never present).
  int first_frame = 0, last_frame = 0;
};

// A scene over time: poses, rendering and geometry. All methods are const and thread-safe except
// set_noise().
class SyntheticSequence {
 public:
  // seed: noise seed, 0 = the scene's own. The scene's seed alone drives the camera jitter, so
  // ground-truth poses do not depend on `seed`. max_frames: keep at most this many frames.
  explicit SyntheticSequence(SceneDescription scene, unsigned seed = 0, std::optional<int> max_frames = {});

  const SceneDescription& scene() const { return scene_; }
  int size() const { return frames_; }
  double timestamp_s(int frame) const { return frame / scene_.fps; }
  const Intrinsics& intrinsics() const { return scene_.camera.intrinsics; }
  unsigned noise_seed() const { return seed_; }
  const KinectNoiseParams& noise() const { return noise_; }
  void set_noise(const KinectNoiseParams& noise) { noise_ = noise; }

  Pose T_world_camera(int frame) const;
  std::vector<ObjectInfo> objects() const;
  int object_count() const { return static_cast<int>(scene_.objects.size()); }
  // Instance id -> the object's class, for every object (shared by all frames).
  const std::shared_ptr<const InstanceClasses>& mask_classes() const { return mask_classes_; }
  // T_world_object of object `id` (1-based) at `frame`, or nullopt when it is absent then. For a
  // person, the pelvis (articulation.h), which is not a rigid body: its limbs move in this frame.
  std::optional<Pose> T_world_object(int id, int frame) const;
  // T_object_part of each part of object `id` (ObjectDesc::parts order) at `frame`, present or not.
  std::vector<Pose> T_object_parts(int id, int frame) const;
  // The lens is covered at `frame` (SceneDescription::occlusions): no depth, a dark image.
  bool covered(int frame) const;

  // Colour, noisy and true depth, instance ids (and surface points on request) of one frame.
  RenderedFrame render(int frame, bool surface_points = false) const;
  // The frame as a FrameSource delivers it: rgb, noisy depth_m, instance-id mask with the class
  // table, intrinsics, T_world_camera_gt.
  Frame frame(int frame) const;

  // Distance (metres) from p to the visible surface of object `id`, p in that object's frame, with
  // its parts at rest (rest_part_poses: a person standing, limbs straight); id 0: the static
  // background, p in the world frame.
  double distance_to_surface_m(int id, const Eigen::Vector3d& p) const;
  // The same with the parts posed as at `frame` (an articulated object's shape changes over time).
  double distance_to_surface_m(int id, const Eigen::Vector3d& p, int frame) const;
  // Triangle mesh of object `id` in its own frame, parts at rest; id 0: the static background in
  // the world frame.
  Mesh mesh(int id, int segments = 32) const;
  // Writes mesh(id) as a binary glTF 2.0 file (atomically).
  void write_glb(int id, const std::filesystem::path& path) const;

  // Ground-truth trajectories (T_world_x, timestamps of the frames): the camera over every frame,
  // an object over the frames where it is present.
  Trajectory camera_trajectory() const;
  Trajectory object_trajectory(int id) const;

  const Renderer& renderer() const { return renderer_; }

 private:
  void check_frame(int frame) const;
  void check_object(int id) const;
  double distance_to_parts_m(int id, const Eigen::Vector3d& p, const std::vector<Pose>& T_object_parts) const;

  SceneDescription scene_;
  Renderer renderer_;
  int frames_ = 0;
  unsigned seed_ = 1;
  KinectNoiseParams noise_;
  std::shared_ptr<const InstanceClasses> mask_classes_;
};

// FrameSource over a SyntheticSequence, rendering each frame when it is asked for.
class SyntheticSource : public FrameSource {
 public:
  explicit SyntheticSource(std::shared_ptr<const SyntheticSequence> sequence);
  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override { return sequence_->intrinsics(); }
  std::optional<int> size() const override { return sequence_->size(); }
  std::string describe() const override;
  const SyntheticSequence& sequence() const { return *sequence_; }

 private:
  std::shared_ptr<const SyntheticSequence> sequence_;
  int next_ = 0;
};

// `scene`: built-in scene name or path to a scene .json; empty = the default scene (kDefaultScene).
// seed: noise seed, 0 = the scene's own. max_frames: stop after this many frames.
// Throws cofusion::Error naming the scene file and field on bad scenes.
std::unique_ptr<FrameSource> make_synthetic_source(const std::string& scene, unsigned seed,
                                                   std::optional<int> max_frames);

}  // namespace cofusion::synthetic
