#include "synthetic/scene.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <sstream>
#include <tuple>

#include "common/error.h"
#include "embedded_assets.h"
#include "io/instance_classes.h"
#include "synthetic/articulation.h"
#include "synthetic/motion.h"

namespace cofusion::synthetic {
namespace {

using json = nlohmann::json;

// A JSON object being read: knows its path for messages ("objects[2].keyframes[0]") and which
// fields were read, so finish() can reject unknown (misspelt) ones.
class Node {
 public:
  Node(const json& j, std::string path, const std::string& origin) : j_(j), path_(std::move(path)), origin_(origin) {
    if (!j_.is_object()) fail_here("expected an object");
  }

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw Error(origin_ + ": " + field_path(key) + ": " + what);
  }
  [[noreturn]] void fail_here(const std::string& what) const {
    throw Error(origin_ + ": " + (path_.empty() ? std::string("(top level)") : path_) + ": " + what);
  }
  std::string field_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  bool has(const std::string& key) const { return j_.contains(key); }

  const json& get(const std::string& key) const {
    used_.insert(key);
    if (!j_.contains(key)) fail(key, "missing field");
    return j_.at(key);
  }

  Node object(const std::string& key) const {
    const json& v = get(key);
    if (!v.is_object()) fail(key, "expected an object");
    return Node(v, field_path(key), origin_);
  }

  std::vector<Node> array_of_objects(const std::string& key) const {
    const json& v = get(key);
    if (!v.is_array()) fail(key, "expected an array of objects");
    std::vector<Node> out;
    for (size_t i = 0; i < v.size(); ++i) {
      const std::string p = field_path(key) + "[" + std::to_string(i) + "]";
      if (!v[i].is_object()) throw Error(origin_ + ": " + p + ": expected an object");
      out.emplace_back(v[i], p, origin_);
    }
    return out;
  }

  double number(const std::string& key) const {
    const json& v = get(key);
    if (!v.is_number()) fail(key, "expected a number");
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail(key, "expected a finite number");
    return d;
  }
  double number(const std::string& key, double fallback) const { return has(key) ? number(key) : fallback; }

  double positive(const std::string& key) const {
    const double d = number(key);
    if (!(d > 0)) fail(key, "must be > 0");
    return d;
  }
  double positive(const std::string& key, double fallback) const { return has(key) ? positive(key) : fallback; }
  double non_negative(const std::string& key, double fallback) const {
    const double d = number(key, fallback);
    if (d < 0) fail(key, "must be >= 0");
    return d;
  }

  long long integer(const std::string& key) const {
    const json& v = get(key);
    if (!v.is_number_integer()) fail(key, "expected an integer");
    return v.get<long long>();
  }
  long long integer(const std::string& key, long long fallback) const { return has(key) ? integer(key) : fallback; }

  bool boolean(const std::string& key, bool fallback) const {
    if (!has(key)) return fallback;
    const json& v = get(key);
    if (!v.is_boolean()) fail(key, "expected true or false");
    return v.get<bool>();
  }

  std::string string(const std::string& key) const {
    const json& v = get(key);
    if (!v.is_string()) fail(key, "expected a string");
    return v.get<std::string>();
  }
  std::string string(const std::string& key, const std::string& fallback) const {
    return has(key) ? string(key) : fallback;
  }

  template <int N>
  Eigen::Matrix<double, N, 1> vec(const std::string& key) const {
    const json& v = get(key);
    const std::string what = "expected an array of " + std::to_string(N) + " numbers";
    if (!v.is_array() || v.size() != N) fail(key, what);
    Eigen::Matrix<double, N, 1> out;
    for (int i = 0; i < N; ++i) {
      if (!v[i].is_number()) fail(key, what);
      out[i] = v[i].get<double>();
      if (!std::isfinite(out[i])) fail(key, what);
    }
    return out;
  }

  // Rejects fields that were never read (typos such as "colour" or "keyframe").
  void finish() const {
    for (const auto& item : j_.items())
      if (!used_.count(item.key())) fail(item.key(), "unknown field");
  }

  const std::string& origin() const { return origin_; }
  const std::string& path() const { return path_; }

 private:
  const json& j_;
  std::string path_;
  const std::string& origin_;
  mutable std::set<std::string> used_;
};

// The object's semantic class: required (generated datasets write it to masks/classes.txt), one
// word so the class table's "id class_name" lines stay parseable.
std::string parse_class(const Node& n, const std::string& object_name) {
  if (!n.has("class"))
    n.fail("class", "missing field: object '" + object_name +
                        "' needs a class (one word, e.g. \"box\", \"can\", \"ball\", \"arm\", \"person\")");
  std::string class_name = n.string("class");
  if (!is_class_name(class_name))
    n.fail("class", "object '" + object_name + "': class '" + class_name +
                        "' must be one non-empty word of printable characters (use '_' for spaces)");
  return class_name;
}

Eigen::Vector3f parse_color(const Node& n, const std::string& key, const json& v) {
  const std::string what = "expected colours as [r, g, b] with values 0..255";
  if (!v.is_array() || v.size() != 3) n.fail(key, what);
  Eigen::Vector3f c;
  for (int i = 0; i < 3; ++i) {
    if (!v[i].is_number()) n.fail(key, what);
    const double d = v[i].get<double>();
    if (!(d >= 0 && d <= 255)) n.fail(key, what);
    c[i] = static_cast<float>(d);
  }
  return c;
}

TextureDesc parse_texture(const Node& n) {
  TextureDesc t;
  const std::string type = n.string("type");
  if (type == "solid") t.type = TextureType::kSolid;
  else if (type == "checker") t.type = TextureType::kChecker;
  else if (type == "stripes") t.type = TextureType::kStripes;
  else if (type == "noise") t.type = TextureType::kNoise;
  else n.fail("type", "unknown texture type '" + type + "' (solid, checker, stripes, noise)");
  const json& colors = n.get("colors");
  if (!colors.is_array() || colors.empty() || colors.size() > 2)
    n.fail("colors", "expected one or two colours [[r, g, b], [r, g, b]]");
  t.colors[0] = parse_color(n, "colors", colors[0]);
  t.colors[1] = colors.size() > 1 ? parse_color(n, "colors", colors[1]) : t.colors[0];
  if (t.type != TextureType::kSolid && colors.size() != 2) n.fail("colors", "this texture needs two colours");
  t.scale_m = n.positive("scale_m", t.scale_m);
  const std::string axis = n.string("axis", "x");
  if (axis == "x") t.axis = 0;
  else if (axis == "y") t.axis = 1;
  else if (axis == "z") t.axis = 2;
  else n.fail("axis", "expected \"x\", \"y\" or \"z\"");
  n.finish();
  return t;
}

TextureDesc texture_or(const Node& n, const std::string& key, const TextureDesc& fallback) {
  return n.has(key) ? parse_texture(n.object(key)) : fallback;
}

ShapeDesc parse_shape(const Node& n) {
  ShapeDesc s;
  const std::string shape = n.string("shape");
  if (shape == "box") {
    s.shape = Shape::kBox;
    s.size_m = n.vec<3>("size");
    if (!(s.size_m.minCoeff() > 0)) n.fail("size", "extents must be > 0");
  } else if (shape == "sphere") {
    s.shape = Shape::kSphere;
    s.radius_m = n.positive("radius");
  } else if (shape == "cylinder") {
    s.shape = Shape::kCylinder;
    s.radius_m = n.positive("radius");
    s.height_m = n.positive("height");
  } else {
    n.fail("shape", "unknown shape '" + shape + "' (box, sphere, cylinder)");
  }
  return s;
}

// Position and rotation fields of a pose or keyframe (the caller checks the remaining fields).
Pose parse_pose_fields(const Node& n, bool allow_look_at) {
  Pose T = Pose::Identity();
  T.translation() = n.vec<3>("position");
  const int rotations = int(n.has("rotation")) + int(n.has("quaternion")) + int(n.has("look_at"));
  if (rotations > 1) n.fail_here("give only one of 'rotation', 'quaternion' and 'look_at'");
  if (n.has("rotation")) {
    const Node r = n.object("rotation");
    const Eigen::Vector3d axis = r.vec<3>("axis");
    if (axis.norm() < 1e-9) r.fail("axis", "must not be zero");
    const double deg = r.number("angle_deg");
    r.finish();
    T.linear() = Eigen::AngleAxisd(deg * std::numbers::pi / 180.0, axis.normalized()).toRotationMatrix();
  } else if (n.has("quaternion")) {
    const Eigen::Vector4d q = n.vec<4>("quaternion");  // qx qy qz qw, as in TUM files
    if (q.norm() < 1e-9) n.fail("quaternion", "must not be zero");
    T.linear() = Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix();
  } else if (n.has("look_at")) {
    if (!allow_look_at) n.fail("look_at", "only camera keyframes may use look_at");
    const Eigen::Vector3d target = n.vec<3>("look_at");
    const Eigen::Vector3d up = n.has("up") ? n.vec<3>("up") : Eigen::Vector3d(0, 0, 1);
    try {
      T.linear() = look_at_rotation(T.translation(), target, up);
    } catch (const Error& e) {
      n.fail("look_at", e.what());
    }
  }
  if (n.has("up") && !n.has("look_at")) n.fail("up", "only meaningful with look_at");
  return T;
}

Pose parse_pose(const Node& n, bool allow_look_at) {
  Pose T = parse_pose_fields(n, allow_look_at);
  n.finish();
  return T;
}

KeyframedPath parse_path(const Node& owner, double fps, bool allow_look_at) {
  KeyframedPath path;
  const std::string interp = owner.string("interpolation", "linear");
  if (interp == "linear") path.interpolation = Interpolation::kLinear;
  else if (interp == "smooth") path.interpolation = Interpolation::kSmooth;
  else owner.fail("interpolation", "expected \"linear\" or \"smooth\"");
  const auto keys = owner.array_of_objects("keyframes");
  if (keys.empty()) owner.fail("keyframes", "needs at least one keyframe");
  for (const Node& k : keys) {
    Keyframe kf;
    if (k.has("frame") == k.has("t")) k.fail_here("give exactly one of 'frame' and 't'");
    if (k.has("frame")) {
      const long long f = k.integer("frame");
      if (f < 0) k.fail("frame", "must be >= 0");
      kf.t_s = static_cast<double>(f) / fps;
    } else {
      kf.t_s = k.number("t");
      if (kf.t_s < 0) k.fail("t", "must be >= 0");
    }
    kf.rotation_given = k.has("rotation") || k.has("quaternion") || k.has("look_at");
    kf.pose = parse_pose(k, allow_look_at);
    if (!path.keyframes.empty() && kf.t_s <= path.keyframes.back().t_s)
      k.fail_here("keyframes must be in strictly increasing time");
    path.keyframes.push_back(kf);
  }
  return path;
}

KinectNoiseParams parse_noise(const Node& n) {
  KinectNoiseParams p;
  p.axial = n.boolean("axial", p.axial);
  p.axial_a0_m = n.non_negative("axial_a0_m", p.axial_a0_m);
  p.axial_a1_per_m = n.non_negative("axial_a1_per_m", p.axial_a1_per_m);
  p.axial_z0_m = n.non_negative("axial_z0_m", p.axial_z0_m);
  p.axial_a2 = n.non_negative("axial_a2", p.axial_a2);
  p.lateral_sigma_px = n.non_negative("lateral_sigma_px", p.lateral_sigma_px);
  const long long sub = n.integer("disparity_subpixel", p.disparity_subpixel);
  if (sub < 0 || sub > 1024) n.fail("disparity_subpixel", "must be in [0, 1024]");
  p.disparity_subpixel = static_cast<int>(sub);
  p.baseline_m = n.positive("baseline_m", p.baseline_m);
  p.max_incidence_deg = n.non_negative("max_incidence_deg", p.max_incidence_deg);
  p.edge_jump_ratio = n.non_negative("edge_jump_ratio", p.edge_jump_ratio);
  p.edge_radius_px = n.non_negative("edge_radius_px", p.edge_radius_px);
  p.edge_drop_probability = n.non_negative("edge_drop_probability", p.edge_drop_probability);
  if (p.edge_drop_probability > 1) n.fail("edge_drop_probability", "must be in [0, 1]");
  p.min_depth_m = n.non_negative("min_depth_m", p.min_depth_m);
  p.max_depth_m = n.non_negative("max_depth_m", p.max_depth_m);
  p.color_sigma = n.non_negative("color_sigma", p.color_sigma);
  n.finish();
  return p;
}

CameraDesc parse_camera(const Node& n, double fps) {
  CameraDesc c;
  if (n.has("intrinsics")) {
    const Node k = n.object("intrinsics");
    c.intrinsics.fx = k.positive("fx", c.intrinsics.fx);
    c.intrinsics.fy = k.positive("fy", c.intrinsics.fy);
    c.intrinsics.cx = k.number("cx", c.intrinsics.cx);
    c.intrinsics.cy = k.number("cy", c.intrinsics.cy);
    const long long w = k.integer("width", c.intrinsics.width), h = k.integer("height", c.intrinsics.height);
    if (w < 1 || w > 8192) k.fail("width", "must be in [1, 8192]");
    if (h < 1 || h > 8192) k.fail("height", "must be in [1, 8192]");
    c.intrinsics.width = static_cast<int>(w);
    c.intrinsics.height = static_cast<int>(h);
    if (!c.intrinsics.plausible()) k.fail_here("implausible intrinsics " + c.intrinsics.to_string());
    k.finish();
  }
  c.path = parse_path(n, fps, true);
  if (n.has("jitter")) {
    const Node j = n.object("jitter");
    c.jitter.translation_m = j.non_negative("translation_m", 0);
    c.jitter.rotation_deg = j.non_negative("rotation_deg", 0);
    c.jitter.min_hz = j.non_negative("min_hz", c.jitter.min_hz);
    c.jitter.max_hz = j.non_negative("max_hz", c.jitter.max_hz);
    if (c.jitter.max_hz < c.jitter.min_hz) j.fail("max_hz", "must be >= min_hz");
    j.finish();
  }
  n.finish();
  return c;
}

TextureDesc plain(float r, float g, float b) {
  TextureDesc t;
  t.colors = {Eigen::Vector3f(r, g, b), Eigen::Vector3f(r, g, b)};
  return t;
}

// "[first, last]" frame numbers with 0 <= first <= last.
std::pair<int, int> parse_frame_range(const Node& n, const std::string& key) {
  const Eigen::Vector2d range = n.vec<2>(key);
  if (range[0] != std::floor(range[0]) || range[1] != std::floor(range[1]) || range[0] < 0 || range[1] < range[0] ||
      range[1] > 1e9)
    n.fail(key, "expected [first, last] frame numbers with 0 <= first <= last");
  return {static_cast<int>(range[0]), static_cast<int>(range[1])};
}

PersonDesc parse_person(const Node& n) {
  PersonDesc p;
  p.height_m = n.positive("height_m", p.height_m);
  if (p.height_m < 0.5 || p.height_m > 2.5) n.fail("height_m", "must be in [0.5, 2.5] metres");
  if (n.has("gait")) {
    const Node g = n.object("gait");
    p.gait.step_hz = g.positive("step_hz", p.gait.step_hz);
    if (p.gait.step_hz > 5) g.fail("step_hz", "must be in (0, 5] steps per second");
    auto angle = [&](const char* key, double fallback) {
      const double d = g.non_negative(key, fallback);
      if (d > 80) g.fail(key, "must be in [0, 80] degrees");
      return d;
    };
    p.gait.arm_swing_deg = angle("arm_swing_deg", p.gait.arm_swing_deg);
    p.gait.leg_swing_deg = angle("leg_swing_deg", p.gait.leg_swing_deg);
    p.gait.torso_twist_deg = angle("torso_twist_deg", p.gait.torso_twist_deg);
    p.gait.phase_deg = g.number("phase_deg", p.gait.phase_deg);
    g.finish();
  }
  ClothesDesc& c = p.clothes;
  c = {plain(225, 175, 140), plain(60, 90, 160), plain(50, 52, 62), plain(30, 26, 22), plain(60, 42, 28)};
  if (n.has("clothes")) {
    const Node k = n.object("clothes");
    c.skin = texture_or(k, "skin", c.skin);
    c.shirt = texture_or(k, "shirt", c.shirt);
    c.trousers = texture_or(k, "trousers", c.trousers);
    c.shoes = texture_or(k, "shoes", c.shoes);
    c.hair = texture_or(k, "hair", c.hair);
    k.finish();
  }
  return p;
}

ObjectDesc parse_object(const Node& n, double fps, size_t index) {
  ObjectDesc d;
  d.name = n.string("name", "object-" + std::to_string(index + 1));
  d.class_name = parse_class(n, d.name);
  const std::string kind = n.string("kind", "rigid");
  if (kind == "rigid") d.kind = ObjectKind::kRigid;
  else if (kind == "person") d.kind = ObjectKind::kPerson;
  else n.fail("kind", "unknown object kind '" + kind + "' (rigid, person)");
  if (d.kind == ObjectKind::kRigid) {
    d.shape = parse_shape(n);
    d.texture = texture_or(n, "texture", plain(128, 128, 128));
    d.parts = {PartDesc{"body", d.shape, d.texture}};
  } else {
    for (const char* key : {"shape", "size", "radius", "height"})
      if (n.has(key)) n.fail(key, "a person has no shape: its body is built from 'height_m'");
    if (n.has("texture")) n.fail("texture", "a person's colours are given by 'clothes'");
    d.person = parse_person(n);
    d.parts = person_parts(d.person);
  }
  if (n.has("pose") == n.has("keyframes")) n.fail_here("give exactly one of 'pose' and 'keyframes'");
  if (n.has("pose")) {
    const Node pose = n.object("pose");
    const bool rotated = pose.has("rotation") || pose.has("quaternion");
    d.path.keyframes.push_back({0.0, parse_pose(pose, false), rotated});
  } else {
    d.path = parse_path(n, fps, false);
  }
  if (n.has("present_frames")) std::tie(d.first_frame, d.last_frame) = parse_frame_range(n, "present_frames");
  n.finish();
  return d;
}


KinectNoiseParams parse_noise_setting(const Node& top) {
  const json& nv = top.get("noise");
  if (nv.is_boolean()) return nv.get<bool>() ? KinectNoiseParams{} : KinectNoiseParams::none();
  if (!nv.is_object()) top.fail("noise", "expected true, false or an object of noise parameters");
  return parse_noise(top.object("noise"));
}

LightDesc parse_light(const Node& l, LightDesc light) {
  if (l.has("direction")) {
    light.direction_world = l.vec<3>("direction");
    if (light.direction_world.norm() < 1e-9) l.fail("direction", "must not be zero");
  }
  light.ambient = l.non_negative("ambient", light.ambient);
  if (light.ambient > 1) l.fail("ambient", "must be in [0, 1]");
  l.finish();
  return light;
}

RoomDesc parse_room(const Node& r) {
  RoomDesc room;
  room.size_m = r.vec<3>("size");
  if (!(room.size_m.minCoeff() > 0)) r.fail("size", "extents must be > 0");
  room.floor = texture_or(r, "floor", plain(150, 120, 90));
  room.walls = texture_or(r, "walls", plain(210, 205, 195));
  room.ceiling = texture_or(r, "ceiling", plain(235, 235, 235));
  r.finish();
  return room;
}

TableDesc parse_table(const Node& t) {
  TableDesc table;
  if (t.has("position")) table.position_m = t.vec<2>("position");
  table.yaw_deg = t.number("yaw_deg", table.yaw_deg);
  if (t.has("top_size")) {
    table.top_size_m = t.vec<2>("top_size");
    if (!(table.top_size_m.minCoeff() > 0)) t.fail("top_size", "extents must be > 0");
  }
  table.height_m = t.positive("height_m", table.height_m);
  table.top_thickness_m = t.positive("top_thickness_m", table.top_thickness_m);
  if (table.top_thickness_m >= table.height_m) t.fail("top_thickness_m", "must be less than height_m");
  table.legs = t.boolean("legs", table.legs);
  table.leg_width_m = t.positive("leg_width_m", table.leg_width_m);
  if (table.legs && 2 * table.leg_width_m > table.top_size_m.minCoeff()) t.fail("leg_width_m", "legs wider than half the top");
  table.texture = texture_or(t, "texture", plain(170, 120, 70));
  table.leg_texture = texture_or(t, "leg_texture", plain(90, 60, 40));
  t.finish();
  return table;
}

StaticDesc parse_static(const Node& n, size_t index) {
  StaticDesc d;
  d.name = n.string("name", "static-" + std::to_string(index));
  d.shape = parse_shape(n);
  d.texture = texture_or(n, "texture", plain(128, 128, 128));
  d.T_world_object = parse_pose(n.object("pose"), false);
  n.finish();
  return d;
}

OcclusionDesc parse_occlusion(const Node& n) {
  OcclusionDesc o;
  const auto [first, last] = parse_frame_range(n, "frames");
  o.first_frame = first;
  o.last_frame = last;
  const std::string kind = n.string("kind", "covered");
  if (kind == "covered") o.kind = OcclusionKind::kCovered;
  else n.fail("kind", "unknown occlusion kind '" + kind + "' (covered)");
  n.finish();
  return o;
}

// The scene's name, description, length, frame rate and seed.
void parse_header(const Node& top, SceneDescription& s) {
  s.name = top.string("name", std::filesystem::path(s.origin).stem().string());
  s.description = top.string("description", "");
  const long long frames = top.integer("frames");
  if (frames < 1 || frames > 1000000) top.fail("frames", "must be in [1, 1000000]");
  s.frames = static_cast<int>(frames);
  s.fps = top.positive("fps", s.fps);
  const long long seed = top.integer("seed", s.seed);
  if (seed < 0 || seed > 0xFFFFFFFFll) top.fail("seed", "must be in [0, 2^32)");
  s.seed = static_cast<unsigned>(seed);
}

}  // namespace

bool SceneDescription::covered(int frame) const {
  return std::any_of(occlusions.begin(), occlusions.end(), [&](const OcclusionDesc& o) {
    return o.kind == OcclusionKind::kCovered && frame >= o.first_frame && frame <= o.last_frame;
  });
}

SceneDescription parse_scene(std::string_view json_text, const std::string& origin) {
  json root;
  try {
    root = json::parse(json_text.begin(), json_text.end());
  } catch (const json::exception& e) {  // parse_error, or out_of_range for a number beyond double
    throw Error(origin + ": invalid JSON: " + e.what());
  }
  SceneDescription s;
  s.origin = origin;
  s.json_text = std::string(json_text);
  const Node top(root, "", s.origin);
  parse_header(top, s);
  s.camera = parse_camera(top.object("camera"), s.fps);
  if (top.has("noise")) s.noise = parse_noise_setting(top);
  if (top.has("light")) s.light = parse_light(top.object("light"), s.light);
  if (top.has("room")) s.room = parse_room(top.object("room"));
  if (top.has("table")) s.table = parse_table(top.object("table"));
  if (top.has("static"))
    for (const Node& n : top.array_of_objects("static")) s.statics.push_back(parse_static(n, s.statics.size()));
  if (top.has("objects")) {
    for (const Node& n : top.array_of_objects("objects")) s.objects.push_back(parse_object(n, s.fps, s.objects.size()));
    if (s.objects.size() > 65535) top.fail("objects", "at most 65535 objects (16-bit instance ids)");
  }
  if (top.has("occlusions"))
    for (const Node& n : top.array_of_objects("occlusions")) s.occlusions.push_back(parse_occlusion(n));
  top.finish();
  return s;
}

SceneDescription load_scene(const std::string& name_or_path) {
  const std::string name = name_or_path.empty() ? std::string(kDefaultScene) : name_or_path;
  if (auto text = assets::scene_json(name)) return parse_scene(*text, name + ".json (built-in scene)");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(name, ec)) {
    std::string known;
    for (const auto& n : builtin_scene_names()) known += (known.empty() ? "" : ", ") + n;
    throw Error("scene '" + name + "' is neither a built-in scene (" + known + ") nor a readable .json file");
  }
  std::ifstream in(name, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (!in && !in.eof()) throw Error(name + ": cannot read the scene file");
  return parse_scene(buffer.str(), name);
}

std::vector<std::string> builtin_scene_names() {
  std::vector<std::string> out;
  for (auto n : assets::scene_names()) out.emplace_back(n);
  return out;
}

}  // namespace cofusion::synthetic
