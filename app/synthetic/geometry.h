#pragma once
// Analytic primitives of the synthetic world, each in its own frame: exact signed distance (double,
// for ground-truth checks) and triangle meshes (for glTF export). The renderer's per-pixel float
// math (intersection, normals, textures) is in primitive_math.h.
//
// Shapes are centred on their origin: a box spans [-half, half]; a cylinder has its axis along z and
// spans z in [-half_height, half_height]; a room is a box seen from the inside (the camera is in it).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

#include "io/frame.h"
#include "synthetic/primitive_math.h"
#include "synthetic/scene.h"

namespace cofusion::synthetic {

struct Primitive {
  PrimitiveKind kind = PrimitiveKind::kBox;
  Eigen::Vector3d half_extents_m{0.05, 0.05, 0.05};  // box, room
  double radius_m = 0.05;                            // sphere, cylinder
  double half_height_m = 0.05;                       // cylinder
  // Texture of every face; a room uses textures[0] floor, [1] walls, [2] ceiling.
  std::array<TextureDesc, 3> textures;
  int instance_id = 0;              // 0 = static background, k = objects[k - 1]
  Pose T_world_primitive = Pose::Identity();  // background parts only; objects move (see renderer)

  // Signed distance (metres) from p (primitive frame) to the surface: negative inside the solid; for
  // a room, negative outside the room. |distance| is the distance to the visible surface.
  double signed_distance(const Eigen::Vector3d& p) const;
};

Primitive make_primitive(const ShapeDesc& shape, const TextureDesc& texture, int instance_id);

// Static background (instance 0) parts of a scene: room, table top and legs, static objects, each
// with T_world_primitive set.
std::vector<Primitive> background_primitives(const SceneDescription& scene);

ShapeF shape_f(const Primitive& p);

// Colour (0..255 per channel, unshaded) of the primitive's solid texture at a surface point given
// in the primitive frame. flat_axis: the coordinate along the face normal is ignored on flat faces,
// so faces that sit on a texture cell boundary do not flicker.
Eigen::Vector3f texture_color(const Primitive& p, const Eigen::Vector3f& point, int flat_axis);

// The texture of the face at `point`: rooms have one for the floor, walls and ceiling.
inline const TextureDesc& texture_of(const Primitive& p, const Eigen::Vector3f& point, int flat_axis) {
  if (p.kind != PrimitiveKind::kRoom) return p.textures[0];
  return flat_axis != 2 ? p.textures[1] : (point.z() < 0 ? p.textures[0] : p.textures[2]);
}

// Triangle mesh in the primitive's (or object's) frame. Counter-clockwise winding seen from the
// side the normals point to (inside for rooms).
struct Mesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;
  std::vector<Eigen::Vector3f> colors;  // 0..1 linear, the texture at each vertex
  std::vector<uint32_t> indices;        // triangles

  void append(const Mesh& other, const Eigen::Isometry3f& T_this_other);
};

// `segments`: subdivisions around spheres and cylinders.
Mesh tessellate(const Primitive& p, int segments = 32);

}  // namespace cofusion::synthetic
