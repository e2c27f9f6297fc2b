#include "synthetic/synthetic_source.h"

#include <algorithm>
#include <limits>

#include "common/error.h"
#include "synthetic/articulation.h"
#include "synthetic/gltf_export.h"
#include "synthetic/motion.h"

namespace cofusion::synthetic {

SyntheticSequence::SyntheticSequence(SceneDescription scene, unsigned seed, std::optional<int> max_frames)
    : scene_(std::move(scene)), renderer_(scene_), frames_(scene_.frames), seed_(seed ? seed : scene_.seed),
      noise_(scene_.noise) {
  if (max_frames) {
    if (*max_frames < 0) throw Error(scene_.origin + ": max_frames must be >= 0");
    frames_ = std::min(frames_, *max_frames);
  }
  auto classes = std::make_shared<InstanceClasses>();
  classes->origin = "scene " + scene_.origin;
  for (int id = 1; id <= object_count(); ++id)
    classes->name_by_id[static_cast<std::uint16_t>(id)] = scene_.objects[id - 1].class_name;
  mask_classes_ = std::move(classes);
}

void SyntheticSequence::check_frame(int frame) const {
  if (frame < 0 || frame >= frames_)
    throw Error(scene_.origin + ": frame " + std::to_string(frame) + " out of range [0, " + std::to_string(frames_) + ")");
}

void SyntheticSequence::check_object(int id) const {
  if (id < 1 || id > object_count())
    throw Error(scene_.origin + ": no object with id " + std::to_string(id) + " (the scene has " +
                std::to_string(object_count()) + ")");
}

Pose SyntheticSequence::T_world_camera(int frame) const {
  check_frame(frame);
  const double t = timestamp_s(frame);
  return interpolate(scene_.camera.path, t) * camera_jitter(scene_.camera.jitter, scene_.seed, t);
}

std::vector<ObjectInfo> SyntheticSequence::objects() const {
  std::vector<ObjectInfo> out;
  for (int id = 1; id <= object_count(); ++id) {
    const ObjectDesc& d = scene_.objects[id - 1];
    out.push_back({id, d.name, d.class_name, d.kind, d.shape.shape, d.first_frame, std::min(d.last_frame, frames_ - 1)});
  }
  return out;
}

std::optional<Pose> SyntheticSequence::T_world_object(int id, int frame) const {
  check_object(id);
  check_frame(frame);
  const ObjectDesc& d = scene_.objects[id - 1];
  if (frame < d.first_frame || frame > d.last_frame) return std::nullopt;
  return object_pose(d, timestamp_s(frame));
}

std::vector<Pose> SyntheticSequence::T_object_parts(int id, int frame) const {
  check_object(id);
  check_frame(frame);
  return part_poses(scene_.objects[id - 1], timestamp_s(frame));
}

bool SyntheticSequence::covered(int frame) const {
  check_frame(frame);
  return scene_.covered(frame);
}

RenderedFrame SyntheticSequence::render(int frame, bool surface_points) const {
  check_frame(frame);
  RenderRequest req;
  req.frame_index = frame;
  req.T_world_camera = T_world_camera(frame);
  for (int id = 1; id <= object_count(); ++id) {
    req.T_world_objects.push_back(T_world_object(id, frame));
    req.T_object_parts.push_back(scene_.objects[id - 1].kind == ObjectKind::kRigid ? std::vector<Pose>{}
                                                                                    : T_object_parts(id, frame));
  }
  req.covered = scene_.covered(frame);
  req.noise = noise_;
  req.seed = seed_;
  req.surface_points = surface_points;
  return renderer_.render(req);
}

Frame SyntheticSequence::frame(int index) const {
  RenderedFrame r = render(index);
  Frame f;
  f.index = index;
  f.timestamp_s = timestamp_s(index);
  f.rgb = r.rgb;
  f.depth_m = r.depth_m;
  f.mask = r.instance_ids;
  f.mask_classes = mask_classes_;
  f.intrinsics = intrinsics();
  f.T_world_camera_gt = T_world_camera(index);
  return f;
}

double SyntheticSequence::distance_to_surface_m(int id, const Eigen::Vector3d& p) const {
  if (id == 0) {
    double best = std::numeric_limits<double>::infinity();
    for (const Primitive& prim : renderer_.background())
      best = std::min(best, std::abs(prim.signed_distance(prim.T_world_primitive.inverse() * p)));
    return best;
  }
  check_object(id);
  return distance_to_parts_m(id, p, rest_part_poses(scene_.objects[id - 1]));
}

double SyntheticSequence::distance_to_surface_m(int id, const Eigen::Vector3d& p, int frame) const {
  if (id == 0) return distance_to_surface_m(0, p);
  return distance_to_parts_m(id, p, T_object_parts(id, frame));
}

double SyntheticSequence::distance_to_parts_m(int id, const Eigen::Vector3d& p,
                                              const std::vector<Pose>& T_object_parts) const {
  const std::vector<Primitive>& parts = renderer_.object_parts()[id - 1];
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < parts.size(); ++i)
    best = std::min(best, std::abs(parts[i].signed_distance(T_object_parts[i].inverse() * p)));
  return best;
}

Mesh SyntheticSequence::mesh(int id, int segments) const {
  if (id == 0) {
    Mesh m;
    for (const Primitive& prim : renderer_.background())
      m.append(tessellate(prim, segments), prim.T_world_primitive.cast<float>());
    return m;
  }
  check_object(id);
  const std::vector<Primitive>& parts = renderer_.object_parts()[id - 1];
  const std::vector<Pose> T_object_parts = rest_part_poses(scene_.objects[id - 1]);
  Mesh m;
  for (size_t i = 0; i < parts.size(); ++i) m.append(tessellate(parts[i], segments), T_object_parts[i].cast<float>());
  return m;
}

void SyntheticSequence::write_glb(int id, const std::filesystem::path& path) const {
  const std::string name = id == 0 ? "background" : scene_.objects[id - 1].name;
  synthetic::write_glb(mesh(id), name, path);
}

Trajectory SyntheticSequence::camera_trajectory() const {
  Trajectory out;
  for (int i = 0; i < frames_; ++i) out.push_back({timestamp_s(i), T_world_camera(i)});
  return out;
}

Trajectory SyntheticSequence::object_trajectory(int id) const {
  check_object(id);
  Trajectory out;
  for (int i = 0; i < frames_; ++i)
    if (auto T = T_world_object(id, i)) out.push_back({timestamp_s(i), *T});
  return out;
}

SyntheticSource::SyntheticSource(std::shared_ptr<const SyntheticSequence> sequence) : sequence_(std::move(sequence)) {}

std::optional<Frame> SyntheticSource::next() {
  if (next_ >= sequence_->size()) return std::nullopt;
  return sequence_->frame(next_++);
}

std::string SyntheticSource::describe() const {
  const auto& s = sequence_->scene();
  const auto& k = sequence_->intrinsics();
  const bool noisy = sequence_->noise().axial || sequence_->noise().disparity_subpixel > 0 ||
                     sequence_->noise().lateral_sigma_px > 0;
  return "synthetic:" + s.name + " (" + std::to_string(sequence_->size()) + " frames, " + std::to_string(k.width) +
         "x" + std::to_string(k.height) + ", " + std::to_string(sequence_->object_count()) + " objects, " +
         (noisy ? "Kinect noise, seed " + std::to_string(sequence_->noise_seed()) : std::string("no noise")) + ")";
}

std::unique_ptr<FrameSource> make_synthetic_source(const std::string& scene, unsigned seed,
                                                   std::optional<int> max_frames) {
  auto sequence = std::make_shared<SyntheticSequence>(load_scene(scene), seed, max_frames);
  return std::make_unique<SyntheticSource>(std::move(sequence));
}

}  // namespace cofusion::synthetic
