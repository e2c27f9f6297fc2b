#pragma once
// Objects made of parts that move against each other. An object's frame follows its path
// (object_pose); each of its parts sits in that frame at a pose that may change every frame
// (part_poses). A rigid object is one part at the origin. A person (PersonDesc) is a pelvis frame
// moved along its floor path, facing its direction of travel, with limbs swung by a walking gait:
// legs alternate, each arm swings against the leg on its side, the chest turns against the pelvis,
// and the pelvis rises and falls so that the lower foot stays on the floor.
#include <vector>

#include "io/frame.h"
#include "synthetic/scene.h"

namespace cofusion::synthetic {

// Half-width of the time window over which a person's direction of travel and speed are measured
// (the displacement between t - w and t + w): turns at keyframes are spread over 2 w.
inline constexpr double kHeadingWindow_s = 0.25;
// Walking speed at which a person's limbs swing by the full gait amplitudes; slower walking scales
// them down linearly, standing still leaves the limbs hanging.
inline constexpr double kFullGaitSpeed_mps = 1.0;

// Body parts of a person of this height and these clothes, in the order part_poses() gives their
// poses: pelvis, torso, neck, head, hair, then per side (left, right) upper arm, forearm, hand, thigh,
// shank, foot.
std::vector<PartDesc> person_parts(const PersonDesc& person);

// Direction of travel (yaw about world z, radians, 0 = +x) and horizontal speed (m/s) of a floor
// path at t_s, from the displacement over [t_s - kHeadingWindow_s, t_s + kHeadingWindow_s]. Where
// the path does not move there, the yaw is that of the nearest stretch in time that does (0 when
// the path never moves).
struct Travel {
  double yaw_rad = 0;
  double speed_mps = 0;
};
Travel travel(const KeyframedPath& path, double t_s);

// Phase (radians; the left leg is furthest forward at pi / 2) and amplitude scale in [0, 1] of a
// person's gait at t_s.
struct GaitState {
  double phase_rad = 0;
  double amplitude = 0;
};
GaitState gait_state(const ObjectDesc& person, double t_s);

// T_world_object at t_s: a rigid object's keyframed path; a person's pelvis (see PersonDesc).
Pose object_pose(const ObjectDesc& object, double t_s);

// T_object_part of each of the object's parts (ObjectDesc::parts order) at t_s.
std::vector<Pose> part_poses(const ObjectDesc& object, double t_s);

// The parts at rest: a person standing with its limbs hanging straight, the pelvis at the object
// origin. The object's exported mesh uses this pose.
std::vector<Pose> rest_part_poses(const ObjectDesc& object);

}  // namespace cofusion::synthetic
