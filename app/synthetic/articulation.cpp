#include "synthetic/articulation.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/error.h"
#include "synthetic/motion.h"

namespace cofusion::synthetic {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// Body proportions as fractions of the standing height H (after Drillis & Contini's segment
// lengths), measured in the pelvis frame: origin between the hip joints, x forward, y left, z up.
struct Proportions {
  // Floor to hip joint: kThigh + kShank + kAnkleHeight = 0.53 H.
  static constexpr double kThigh = 0.245, kShank = 0.246, kAnkleHeight = 0.039;
  static constexpr double kHipHalfSpacing = 0.055;
  static constexpr double kThighRadius = 0.034, kShankRadius = 0.026;
  static constexpr double kFootLength = 0.15, kFootWidth = 0.055, kHeelBehindAnkle = 0.04;
  static constexpr double kPelvisDepth = 0.11, kPelvisWidth = 0.19, kPelvisBottom = -0.05, kPelvisTop = 0.07;
  static constexpr double kTorsoDepth = 0.12, kTorsoWidth = 0.20, kTorsoBottom = 0.06, kTorsoTop = 0.30;
  static constexpr double kNeckRadius = 0.03, kNeckBottom = 0.28, kNeckTop = 0.36;
  static constexpr double kHeadRadius = 0.062, kHeadCentre = 0.396;  // chin at 0.864 H above the floor
  static constexpr double kHairRadius = 0.064, kHairBack = 0.008, kHairUp = 0.01;  // hair top at H
  static constexpr double kShoulderHeight = 0.288, kShoulderHalfSpacing = 0.128;
  static constexpr double kUpperArm = 0.186, kUpperArmRadius = 0.028;
  static constexpr double kForearm = 0.146, kForearmRadius = 0.022, kHandRadius = 0.027;
  static constexpr double kArmAbductionDeg = 4;  // arms hang slightly away from the torso
};

// Joint angles of one body pose (radians). Per side: index 0 = left, 1 = right.
struct Angles {
  double hip[2] = {0, 0};       // thigh forward of vertical
  double knee[2] = {0, 0};      // shank bent back against the thigh
  double shoulder[2] = {0, 0};  // upper arm forward of hanging
  double elbow[2] = {0, 0};     // forearm bent forward against the upper arm
  double toe_off[2] = {0, 0};   // foot pitched toes down from level (heel raised)
  double pelvis_yaw = 0, chest_yaw = 0;
};

Angles gait_angles(const GaitDesc& g, const GaitState& s) {
  Angles a;
  const double sin_p = std::sin(s.phase_rad), cos_p = std::cos(s.phase_rad);
  const double leg = g.leg_swing_deg * kDeg * s.amplitude, arm = g.arm_swing_deg * kDeg * s.amplitude;
  for (int side = 0; side < 2; ++side) {
    const double sign = side == 0 ? 1.0 : -1.0;  // the right side is half a cycle behind the left
    a.hip[side] = sign * leg * sin_p;
    // The knee bends while the leg swings forward (the hip angle rising), most at mid-swing.
    a.knee[side] = s.amplitude * 4 * kDeg + 2 * leg * std::max(0.0, sign * cos_p);
    // A leg behind the body rolls onto its toes, which keeps the pelvis from dropping as far as
    // straight legs would make it (its rise and fall stays a few centimetres).
    a.toe_off[side] = 0.6 * std::max(0.0, -a.hip[side]);
    a.shoulder[side] = -sign * arm * sin_p;  // against the leg on the same side
    a.elbow[side] = s.amplitude * 10 * kDeg + 0.7 * std::max(0.0, a.shoulder[side]);
  }
  // The chest turns with the forward arm, the pelvis with the forward leg (opposite ways).
  a.chest_yaw = g.torso_twist_deg * kDeg * s.amplitude * sin_p;
  a.pelvis_yaw = -0.5 * g.torso_twist_deg * kDeg * s.amplitude * sin_p;
  return a;
}

Pose translation(double x, double y, double z) {
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}
Pose rotation(double angle_rad, const Eigen::Vector3d& axis) {
  Pose T = Pose::Identity();
  T.linear() = Eigen::AngleAxisd(angle_rad, axis).toRotationMatrix();
  return T;
}

ShapeDesc box(double sx, double sy, double sz) {
  ShapeDesc s;
  s.shape = Shape::kBox;
  s.size_m = Eigen::Vector3d(sx, sy, sz);
  return s;
}
ShapeDesc cylinder(double radius, double length) {
  ShapeDesc s;
  s.shape = Shape::kCylinder;
  s.radius_m = radius;
  s.height_m = length;
  return s;
}
ShapeDesc sphere(double radius) {
  ShapeDesc s;
  s.shape = Shape::kSphere;
  s.radius_m = radius;
  return s;
}

// The posed body: every part's shape, texture and T_pelvis_part, in person_parts() order. One
// function builds both, so the list of parts and the list of poses cannot disagree.
struct PosedPart {
  PartDesc part;
  Pose T_pelvis_part;
};

std::vector<PosedPart> pose_body(const PersonDesc& person, const Angles& a) {
  using P = Proportions;
  const double H = person.height_m;
  const ClothesDesc& c = person.clothes;
  std::vector<PosedPart> out;
  auto add = [&](const char* name, const ShapeDesc& shape, const TextureDesc& texture, const Pose& T) {
    out.push_back({PartDesc{name, shape, texture}, T});
  };
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX(), Y = Eigen::Vector3d::UnitY(), Z = Eigen::Vector3d::UnitZ();
  const Pose T_pelvis_hips = rotation(a.pelvis_yaw, Z);  // the hip girdle, turned with the stride
  const Pose T_pelvis_chest = rotation(a.chest_yaw, Z);

  add("pelvis", box(P::kPelvisDepth * H, P::kPelvisWidth * H, (P::kPelvisTop - P::kPelvisBottom) * H), c.trousers,
      T_pelvis_hips * translation(0, 0, 0.5 * (P::kPelvisTop + P::kPelvisBottom) * H));
  add("torso", box(P::kTorsoDepth * H, P::kTorsoWidth * H, (P::kTorsoTop - P::kTorsoBottom) * H), c.shirt,
      T_pelvis_chest * translation(0, 0, 0.5 * (P::kTorsoTop + P::kTorsoBottom) * H));
  add("neck", cylinder(P::kNeckRadius * H, (P::kNeckTop - P::kNeckBottom) * H), c.skin,
      translation(0, 0, 0.5 * (P::kNeckTop + P::kNeckBottom) * H));
  add("head", sphere(P::kHeadRadius * H), c.skin, translation(0, 0, P::kHeadCentre * H));
  add("hair", sphere(P::kHairRadius * H), c.hair,
      translation(-P::kHairBack * H, 0, (P::kHeadCentre + P::kHairUp) * H));

  static const char* kNames[2][6] = {
      {"left_upper_arm", "left_forearm", "left_hand", "left_thigh", "left_shank", "left_foot"},
      {"right_upper_arm", "right_forearm", "right_hand", "right_thigh", "right_shank", "right_foot"}};
  for (int side = 0; side < 2; ++side) {
    const double sy = side == 0 ? 1.0 : -1.0;
    const char* const* name = kNames[side];
    // Arm: joint frames whose -z runs down the limb; a limb's cylinder hangs below its joint.
    const Pose shoulder = T_pelvis_chest * translation(0, sy * P::kShoulderHalfSpacing * H, P::kShoulderHeight * H) *
                          rotation(-a.shoulder[side], Y) * rotation(sy * P::kArmAbductionDeg * kDeg, X);
    add(name[0], cylinder(P::kUpperArmRadius * H, P::kUpperArm * H), c.shirt,
        shoulder * translation(0, 0, -0.5 * P::kUpperArm * H));
    const Pose elbow = shoulder * translation(0, 0, -P::kUpperArm * H) * rotation(-a.elbow[side], Y);
    add(name[1], cylinder(P::kForearmRadius * H, P::kForearm * H), c.skin,
        elbow * translation(0, 0, -0.5 * P::kForearm * H));
    add(name[2], sphere(P::kHandRadius * H), c.skin,
        elbow * translation(0, 0, -(P::kForearm + 0.8 * P::kHandRadius) * H));
    // Leg: the foot is turned back level with the pelvis (flat on the floor when it stands on it),
    // then rolled onto its toes when the leg is behind.
    const Pose hip = T_pelvis_hips * translation(0, sy * P::kHipHalfSpacing * H, 0) * rotation(-a.hip[side], Y);
    add(name[3], cylinder(P::kThighRadius * H, P::kThigh * H), c.trousers,
        hip * translation(0, 0, -0.5 * P::kThigh * H));
    const Pose knee = hip * translation(0, 0, -P::kThigh * H) * rotation(a.knee[side], Y);
    add(name[4], cylinder(P::kShankRadius * H, P::kShank * H), c.trousers,
        knee * translation(0, 0, -0.5 * P::kShank * H));
    const Pose ankle =
        knee * translation(0, 0, -P::kShank * H) * rotation(a.hip[side] - a.knee[side] + a.toe_off[side], Y);
    add(name[5], box(P::kFootLength * H, P::kFootWidth * H, P::kAnkleHeight * H), c.shoes,
        ankle * translation((0.5 * P::kFootLength - P::kHeelBehindAnkle) * H, 0, -0.5 * P::kAnkleHeight * H));
  }
  return out;
}

// Height of the pelvis origin above the floor that puts the lowest corner of either foot on it.
double pelvis_height(const std::vector<PosedPart>& body) {
  double lowest = 0;
  for (const PosedPart& p : body) {
    if (p.part.name.find("foot") == std::string::npos) continue;
    const Eigen::Vector3d half = p.part.shape.size_m / 2;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d corner((c & 1 ? 1 : -1) * half.x(), (c & 2 ? 1 : -1) * half.y(), (c & 4 ? 1 : -1) * half.z());
      lowest = std::min(lowest, (p.T_pelvis_part * corner).z());
    }
  }
  return -lowest;
}

bool any_rotation(const KeyframedPath& path) {
  return std::any_of(path.keyframes.begin(), path.keyframes.end(), [](const Keyframe& k) { return k.rotation_given; });
}

}  // namespace

std::vector<PartDesc> person_parts(const PersonDesc& person) {
  std::vector<PartDesc> out;
  for (PosedPart& p : pose_body(person, Angles{})) out.push_back(std::move(p.part));
  return out;
}

Travel travel(const KeyframedPath& path, double t_s) {
  auto displacement = [&](double t) -> Eigen::Vector2d {
    return (interpolate(path, t + kHeadingWindow_s).translation() - interpolate(path, t - kHeadingWindow_s).translation())
        .head<2>();
  };
  constexpr double kStill_m = 1e-6;
  Travel out;
  const Eigen::Vector2d d = displacement(t_s);
  out.speed_mps = d.norm() / (2 * kHeadingWindow_s);
  if (d.norm() > kStill_m) {
    out.yaw_rad = std::atan2(d.y(), d.x());
    return out;
  }
  // Standing: face the way of the nearest movement in time (the coming one on a tie).
  if (path.keyframes.empty()) return out;
  const double span = path.keyframes.back().t_s - path.keyframes.front().t_s + 2 * kHeadingWindow_s;
  const double step = 0.5 * kHeadingWindow_s;
  for (double dt = step; dt <= span + std::abs(t_s - path.keyframes.front().t_s) + step; dt += step) {
    for (const double t : {t_s + dt, t_s - dt}) {
      const Eigen::Vector2d e = displacement(t);
      if (e.norm() > kStill_m) {
        out.yaw_rad = std::atan2(e.y(), e.x());
        return out;
      }
    }
  }
  return out;
}

GaitState gait_state(const ObjectDesc& person, double t_s) {
  const GaitDesc& g = person.person.gait;
  GaitState s;
  // One cycle is two steps. Phase pi / 2 (left leg forward) is reached at t = 1 / (2 step_hz).
  s.phase_rad = std::numbers::pi * g.step_hz * t_s + g.phase_deg * kDeg;
  s.amplitude = std::clamp(travel(person.path, t_s).speed_mps / kFullGaitSpeed_mps, 0.0, 1.0);
  return s;
}

Pose object_pose(const ObjectDesc& object, double t_s) {
  if (object.kind == ObjectKind::kRigid) return interpolate(object.path, t_s);
  const Pose floor = interpolate(object.path, t_s);
  Pose T_world_pelvis = Pose::Identity();
  T_world_pelvis.linear() = any_rotation(object.path)
                                ? floor.linear()
                                : Eigen::AngleAxisd(travel(object.path, t_s).yaw_rad, Eigen::Vector3d::UnitZ())
                                      .toRotationMatrix();
  const Angles a = gait_angles(object.person.gait, gait_state(object, t_s));
  T_world_pelvis.translation() = floor.translation() + Eigen::Vector3d(0, 0, pelvis_height(pose_body(object.person, a)));
  return T_world_pelvis;
}

std::vector<Pose> part_poses(const ObjectDesc& object, double t_s) {
  if (object.kind == ObjectKind::kRigid) return rest_part_poses(object);
  std::vector<Pose> out;
  for (const PosedPart& p : pose_body(object.person, gait_angles(object.person.gait, gait_state(object, t_s))))
    out.push_back(p.T_pelvis_part);
  return out;
}

std::vector<Pose> rest_part_poses(const ObjectDesc& object) {
  if (object.kind == ObjectKind::kRigid) return std::vector<Pose>(object.parts.size(), Pose::Identity());
  std::vector<Pose> out;
  for (const PosedPart& p : pose_body(object.person, Angles{})) out.push_back(p.T_pelvis_part);
  return out;
}

}  // namespace cofusion::synthetic
