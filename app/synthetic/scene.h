#pragma once
// Description of a synthetic dynamic scene, parsed from JSON (format documented in
// assets/scenes/README.md and summarised below). Plain data; evaluation of poses over time lives in
// motion.h, rendering in renderer.h.
//
// World frame: metres, z up (floor at z = 0). Camera frame: OpenCV (x right, y down, z forward).
// Poses are T_world_x (x-to-world), as in TUM ground truth.
//
//   {
//     "name": "...", "description": "...",
//     "frames": 120, "fps": 30, "seed": 7,
//     "camera": { "intrinsics": {"fx":525,"fy":525,"cx":319.5,"cy":239.5,"width":640,"height":480},
//                 "interpolation": "linear" | "smooth",
//                 "keyframes": [ {"frame": 0, "position": [x,y,z], "look_at": [x,y,z]}, ... ],
//                 "jitter": {"translation_m": 0.003, "rotation_deg": 0.3, "min_hz": 0.3, "max_hz": 2} },
//     "noise": true | false | { KinectNoiseParams fields, all optional },
//     "light": {"direction": [x,y,z], "ambient": 0.35},
//     "room": {"size": [sx,sy,sz], "floor": TEX, "walls": TEX, "ceiling": TEX},
//     "table": {"position": [x,y], "yaw_deg": 0, "top_size": [sx,sy], "height_m": 0.75,
//               "top_thickness_m": 0.04, "legs": true, "leg_width_m": 0.06, "texture": TEX, "leg_texture": TEX},
//     "static":  [ {"name": "...", SHAPE, "texture": TEX, "pose": POSE} ],
//     "objects": [ {"name": "...", "class": "box", SHAPE, "texture": TEX, "present_frames": [first, last],
//                   "interpolation": "linear" | "smooth", "keyframes": [ KEY, ... ] (or "pose": POSE)},
//                  {"name": "...", "class": "person", "kind": "person", "height_m": 1.75, "present_frames": [first, last],
//                   "interpolation": ..., "keyframes": [ KEY, ... ] (feet on the floor, see PersonDesc),
//                   "gait": {"step_hz": 1.8, "arm_swing_deg": 25, "leg_swing_deg": 25, "torso_twist_deg": 6,
//                            "phase_deg": 0},
//                   "clothes": {"skin": TEX, "shirt": TEX, "trousers": TEX, "shoes": TEX, "hair": TEX}} ],
//     "occlusions": [ {"frames": [first, last], "kind": "covered"} ]
//   }
//   SHAPE: "shape": "box", "size": [sx,sy,sz] | "shape": "sphere", "radius": r
//        | "shape": "cylinder", "radius": r, "height": h        (centred on the object origin, axis z)
//   TEX:   {"type": "solid"|"checker"|"stripes"|"noise", "colors": [[r,g,b], [r,g,b]], "scale_m": 0.05,
//           "axis": "x"|"y"|"z" (stripes)}                       (solid 3-D textures in the shape's frame)
//   POSE:  {"position": [x,y,z], "rotation": {"axis": [x,y,z], "angle_deg": a} | "quaternion": [qx,qy,qz,qw]
//           | "look_at": [x,y,z], "up": [x,y,z] (camera only)}
//   KEY:   POSE plus "frame": n or "t": seconds
#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/intrinsics.h"
#include "io/frame.h"
#include "synthetic/noise.h"

namespace cofusion::synthetic {

// Name of the scene `cofusion run` and `generate` use when none is given.
inline constexpr std::string_view kDefaultScene = "static_room";

enum class Shape { kBox, kSphere, kCylinder };

struct ShapeDesc {
  Shape shape = Shape::kBox;
  Eigen::Vector3d size_m{0.1, 0.1, 0.1};  // box: full extents along x, y, z
  double radius_m = 0.05;                 // sphere, cylinder
  double height_m = 0.1;                  // cylinder: full length along z
};

enum class TextureType { kSolid, kChecker, kStripes, kNoise };

struct TextureDesc {
  TextureType type = TextureType::kSolid;
  std::array<Eigen::Vector3f, 2> colors{Eigen::Vector3f(200, 200, 200), Eigen::Vector3f(60, 60, 60)};  // 0..255
  double scale_m = 0.05;  // checker cell / stripe half-period / noise feature size, metres
  int axis = 0;           // stripes: the axis (0 = x, 1 = y, 2 = z of the shape's frame) they vary along
};

struct Keyframe {
  double t_s = 0;  // seconds from the first frame ("frame": n is stored as n / fps)
  Pose pose = Pose::Identity();
  bool rotation_given = false;  // the key named a rotation (otherwise pose.linear() is identity)
};

enum class Interpolation { kLinear, kSmooth };  // smooth: ease in/out (smoothstep) on each segment

struct KeyframedPath {
  std::vector<Keyframe> keyframes;  // sorted by t_s, at least one
  Interpolation interpolation = Interpolation::kLinear;
};

// Hand-held-like smooth camera shake: each of the 6 degrees of freedom is a sum of sines with
// frequencies in [min_hz, max_hz] and phases drawn from the scene seed; RMS amplitude as given.
struct JitterDesc {
  double translation_m = 0;  // RMS per axis, metres
  double rotation_deg = 0;   // RMS per axis, degrees
  double min_hz = 0.3;
  double max_hz = 2.0;
};

struct CameraDesc {
  Intrinsics intrinsics;  // defaults: 525/525/319.5/239.5, 640x480
  KeyframedPath path;
  JitterDesc jitter;
};

struct LightDesc {
  Eigen::Vector3d direction_world{0.3, 0.5, -1.0};  // direction the light travels (towards the floor)
  double ambient = 0.35;                              // 0..1, the rest is Lambertian
};

struct RoomDesc {
  Eigen::Vector3d size_m{5.0, 4.0, 2.8};  // x in [-sx/2, sx/2], y in [-sy/2, sy/2], z in [0, sz]
  TextureDesc floor, walls, ceiling;
};

struct TableDesc {
  Eigen::Vector2d position_m{0, 0};  // centre of the top, on the floor plane
  double yaw_deg = 0;
  Eigen::Vector2d top_size_m{1.4, 0.8};
  double height_m = 0.75;  // floor to top surface
  double top_thickness_m = 0.04;
  bool legs = true;  // false: one solid box from the floor to the top
  double leg_width_m = 0.06;
  TextureDesc texture, leg_texture;
};

// A rigid part of the static background (instance id 0).
struct StaticDesc {
  std::string name;
  ShapeDesc shape;
  TextureDesc texture;
  Pose T_world_object = Pose::Identity();
};

// One rigid piece of an object, placed in the object's frame by a pose that may change every frame
// (articulation.h computes it). Every part of an object carries the object's instance id.
struct PartDesc {
  std::string name;  // "body" for a rigid object; "torso", "left_thigh", ... for a person
  ShapeDesc shape;
  TextureDesc texture;
};

// Walking gait of a person. One gait cycle (a stride: a left and a right step) takes 2 / step_hz
// seconds; the swings are scaled down when the person walks slower than kFullGaitSpeed and vanish
// when it stands still.
struct GaitDesc {
  double step_hz = 1.8;          // steps per second
  double arm_swing_deg = 25;     // shoulder swing amplitude, each way from hanging straight down
  double leg_swing_deg = 25;     // hip swing amplitude, each way from vertical. Feet that do not
                                 // slide: asin(speed / (2 step_hz 0.49 height_m)), about 22 degrees
                                 // at 1.3 m/s, 1.9 steps/s and 1.75 m
  double torso_twist_deg = 6;    // chest yaw against the pelvis, in time with the arms
  double phase_deg = 0;          // offset of the cycle, so that people in one scene are not in step
};

struct ClothesDesc {
  TextureDesc skin, shirt, trousers, shoes, hair;
};

// An articulated, non-rigid person built from primitives (torso, pelvis, neck, head, upper and lower
// arms, hands, thighs, shanks, feet). Its object frame is the pelvis: origin between the hip joints,
// x forward (the way it faces), y to its left, z up. The keyframes give the point on the floor below
// the pelvis (their z is the floor height there, usually 0); the pelvis rides above it at hip height,
// rising and falling with the stride so that the lower foot touches the floor. Keys without a
// rotation make the body face its direction of travel (yaw from the path, smoothed over
// kHeadingWindow_s); once any key gives a rotation, the keys' rotations are used as for rigid objects.
struct PersonDesc {
  double height_m = 1.75;  // floor to the top of the head, standing
  GaitDesc gait;
  ClothesDesc clothes;
};

enum class ObjectKind { kRigid, kPerson };

// An object with its own instance id (1-based position in SceneDescription::objects): a rigid shape
// (kind kRigid: one part, "body", at the object origin) or a person (kind kPerson: the body parts
// from person_parts(), moved by the gait).
struct ObjectDesc {
  std::string name;
  std::string class_name;         // semantic class ("box", "can", "person", ...), required, one word
  ObjectKind kind = ObjectKind::kRigid;
  ShapeDesc shape;                // kRigid: the shape (also parts[0])
  TextureDesc texture;            // kRigid
  PersonDesc person;              // kPerson
  std::vector<PartDesc> parts;    // what is rendered, in the object frame; at least one
  KeyframedPath path;             // kRigid: T_world_object over time; kPerson: the floor path (see PersonDesc)
  int first_frame = 0;            // present (rendered, has ground truth) in [first_frame, last_frame]
  int last_frame = 1 << 30;
};

// Something between the scene and the sensor for a span of frames. kCovered: the lens is covered
// (a hand over it): no depth at all and a nearly black, noisy colour image; the camera keeps moving
// on its path and its ground truth is the true pose.
enum class OcclusionKind { kCovered };

struct OcclusionDesc {
  int first_frame = 0, last_frame = 0;  // inclusive
  OcclusionKind kind = OcclusionKind::kCovered;
};

struct SceneDescription {
  std::string name;
  std::string description;
  std::string origin;  // file or built-in name it was read from, for messages
  std::string json_text;  // the text it was parsed from (copied into generated datasets)
  int frames = 90;
  double fps = 30;
  unsigned seed = 1;
  CameraDesc camera;
  KinectNoiseParams noise;
  LightDesc light;
  std::optional<RoomDesc> room;
  std::optional<TableDesc> table;
  std::vector<StaticDesc> statics;
  std::vector<ObjectDesc> objects;
  std::vector<OcclusionDesc> occlusions;

  // The lens is covered at `frame` (an occlusion of kind kCovered spans it).
  bool covered(int frame) const;
};

// Parses a scene. `origin` names the file (or built-in scene) in error messages, which read
// "<origin>: <field path>: <problem>", e.g. "one_object.json: objects[0].keyframes[1].position:
// expected an array of 3 numbers". Unknown fields are errors (they are usually typos).
SceneDescription parse_scene(std::string_view json_text, const std::string& origin);

// `name_or_path`: a built-in scene name (see builtin_scene_names()), or a path to a .json file;
// empty = kDefaultScene. Throws cofusion::Error naming the scene when it cannot be found or parsed.
SceneDescription load_scene(const std::string& name_or_path);

std::vector<std::string> builtin_scene_names();

}  // namespace cofusion::synthetic
