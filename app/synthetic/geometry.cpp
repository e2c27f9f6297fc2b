#include "synthetic/geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace cofusion::synthetic {

double Primitive::signed_distance(const Eigen::Vector3d& p) const {
  auto box_sdf = [&] {
    const Eigen::Vector3d q = p.cwiseAbs() - half_extents_m;
    return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
  };
  switch (kind) {
    case PrimitiveKind::kBox: return box_sdf();
    case PrimitiveKind::kRoom: return -box_sdf();
    case PrimitiveKind::kSphere: return p.norm() - radius_m;
    case PrimitiveKind::kCylinder: {
      const Eigen::Vector2d d(p.head<2>().norm() - radius_m, std::abs(p.z()) - half_height_m);
      return std::min(d.maxCoeff(), 0.0) + d.cwiseMax(0.0).norm();
    }
  }
  return 0;
}

Primitive make_primitive(const ShapeDesc& shape, const TextureDesc& texture, int instance_id) {
  Primitive p;
  p.instance_id = instance_id;
  p.textures = {texture, texture, texture};
  switch (shape.shape) {
    case Shape::kBox:
      p.kind = PrimitiveKind::kBox;
      p.half_extents_m = shape.size_m / 2;
      break;
    case Shape::kSphere:
      p.kind = PrimitiveKind::kSphere;
      p.radius_m = shape.radius_m;
      break;
    case Shape::kCylinder:
      p.kind = PrimitiveKind::kCylinder;
      p.radius_m = shape.radius_m;
      p.half_height_m = shape.height_m / 2;
      break;
  }
  return p;
}

std::vector<Primitive> background_primitives(const SceneDescription& scene) {
  std::vector<Primitive> out;
  if (scene.room) {
    Primitive room;
    room.kind = PrimitiveKind::kRoom;
    room.half_extents_m = scene.room->size_m / 2;
    room.textures = {scene.room->floor, scene.room->walls, scene.room->ceiling};
    room.T_world_primitive.translation() = Eigen::Vector3d(0, 0, scene.room->size_m.z() / 2);
    out.push_back(room);
  }
  if (scene.table) {
    const TableDesc& t = *scene.table;
    Pose T_world_table = Pose::Identity();  // table frame: origin on the floor below the top's centre
    T_world_table.translation() = Eigen::Vector3d(t.position_m.x(), t.position_m.y(), 0);
    T_world_table.linear() =
        Eigen::AngleAxisd(t.yaw_deg * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    auto add_box = [&](const Eigen::Vector3d& size, const Eigen::Vector3d& centre, const TextureDesc& tex) {
      ShapeDesc s;
      s.shape = Shape::kBox;
      s.size_m = size;
      Primitive p = make_primitive(s, tex, 0);
      Pose T_table_box = Pose::Identity();
      T_table_box.translation() = centre;
      p.T_world_primitive = T_world_table * T_table_box;
      out.push_back(p);
    };
    if (t.legs) {
      add_box({t.top_size_m.x(), t.top_size_m.y(), t.top_thickness_m}, {0, 0, t.height_m - t.top_thickness_m / 2},
              t.texture);
      const double leg_h = t.height_m - t.top_thickness_m;
      const double lx = t.top_size_m.x() / 2 - t.leg_width_m / 2, ly = t.top_size_m.y() / 2 - t.leg_width_m / 2;
      for (int sx : {-1, 1})
        for (int sy : {-1, 1})
          add_box({t.leg_width_m, t.leg_width_m, leg_h}, {sx * lx, sy * ly, leg_h / 2}, t.leg_texture);
    } else {
      add_box({t.top_size_m.x(), t.top_size_m.y(), t.height_m}, {0, 0, t.height_m / 2}, t.texture);
    }
  }
  for (const StaticDesc& s : scene.statics) {
    Primitive p = make_primitive(s.shape, s.texture, 0);
    p.T_world_primitive = s.T_world_object;
    out.push_back(p);
  }
  return out;
}

ShapeF shape_f(const Primitive& p) {
  ShapeF s;
  s.kind = p.kind;
  s.half_extents = p.half_extents_m.cast<float>();
  s.radius = static_cast<float>(p.radius_m);
  s.half_height = static_cast<float>(p.half_height_m);
  return s;
}

Eigen::Vector3f texture_color(const Primitive& p, const Eigen::Vector3f& point, int flat_axis) {
  return texture_color(texture_of(p, point, flat_axis), point, flat_axis);
}

void Mesh::append(const Mesh& other, const Eigen::Isometry3f& T_this_other) {
  const uint32_t base = static_cast<uint32_t>(positions.size());
  for (size_t i = 0; i < other.positions.size(); ++i) {
    positions.push_back(T_this_other * other.positions[i]);
    normals.push_back(T_this_other.linear() * other.normals[i]);
    colors.push_back(other.colors[i]);
  }
  for (uint32_t idx : other.indices) indices.push_back(base + idx);
}

namespace {

// Appends a vertex with its colour from the texture; returns its index.
uint32_t add_vertex(Mesh& m, const Primitive& p, const Eigen::Vector3f& pos, const Eigen::Vector3f& n, int flat_axis) {
  m.positions.push_back(pos);
  m.normals.push_back(n);
  m.colors.push_back(texture_color(p, pos, flat_axis) / 255.0f);
  return static_cast<uint32_t>(m.positions.size() - 1);
}

// Triangle (a, b, c), flipped if needed so it winds counter-clockwise around `outward`.
void add_triangle(Mesh& m, uint32_t a, uint32_t b, uint32_t c, const Eigen::Vector3f& outward) {
  const Eigen::Vector3f n = (m.positions[b] - m.positions[a]).cross(m.positions[c] - m.positions[a]);
  if (n.dot(outward) < 0) std::swap(b, c);
  m.indices.insert(m.indices.end(), {a, b, c});
}

void box_faces(Mesh& m, const Primitive& p, bool inward) {
  const Eigen::Vector3f h = p.half_extents_m.cast<float>();
  for (int axis = 0; axis < 3; ++axis) {
    const int j = (axis + 1) % 3, k = (axis + 2) % 3;
    for (float sign : {-1.0f, 1.0f}) {
      Eigen::Vector3f n = Eigen::Vector3f::Zero();
      n[axis] = inward ? -sign : sign;
      uint32_t idx[4];
      const float corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
      for (int c = 0; c < 4; ++c) {
        Eigen::Vector3f v;
        v[axis] = sign * h[axis];
        v[j] = corners[c][0] * h[j];
        v[k] = corners[c][1] * h[k];
        idx[c] = add_vertex(m, p, v, n, axis);
      }
      add_triangle(m, idx[0], idx[1], idx[2], n);
      add_triangle(m, idx[0], idx[2], idx[3], n);
    }
  }
}

}  // namespace

Mesh tessellate(const Primitive& p, int segments) {
  segments = std::max(segments, 3);
  Mesh m;
  const float two_pi = 2 * std::numbers::pi_v<float>;
  switch (p.kind) {
    case PrimitiveKind::kBox: box_faces(m, p, false); break;
    case PrimitiveKind::kRoom: box_faces(m, p, true); break;
    case PrimitiveKind::kSphere: {
      const float r = static_cast<float>(p.radius_m);
      const int rings = std::max(segments / 2, 2);
      // Vertex rows from the south to the north pole; each pole is a single vertex.
      std::vector<std::vector<uint32_t>> rows;
      for (int i = 0; i <= rings; ++i) {
        const float lat = -std::numbers::pi_v<float> / 2 + std::numbers::pi_v<float> * i / rings;
        std::vector<uint32_t> row;
        const int count = (i == 0 || i == rings) ? 1 : segments;
        for (int s = 0; s < count; ++s) {
          const float lon = two_pi * s / segments;
          const Eigen::Vector3f n(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat));
          row.push_back(add_vertex(m, p, r * n, n, -1));
        }
        rows.push_back(row);
      }
      for (int i = 0; i < rings; ++i) {
        const auto& lo = rows[i];
        const auto& hi = rows[i + 1];
        for (int s = 0; s < segments; ++s) {
          const int s1 = (s + 1) % segments;
          const uint32_t a = lo[lo.size() == 1 ? 0 : s], b = lo[lo.size() == 1 ? 0 : s1];
          const uint32_t c = hi[hi.size() == 1 ? 0 : s1], d = hi[hi.size() == 1 ? 0 : s];
          const Eigen::Vector3f out = (m.positions[a] + m.positions[b] + m.positions[c] + m.positions[d]);
          if (a != b) add_triangle(m, a, b, c, out);
          if (c != d) add_triangle(m, a, c, d, out);
        }
      }
      break;
    }
    case PrimitiveKind::kCylinder: {
      const float r = static_cast<float>(p.radius_m), hh = static_cast<float>(p.half_height_m);
      std::vector<uint32_t> bottom, top;
      for (int s = 0; s < segments; ++s) {
        const float lon = two_pi * s / segments;
        const Eigen::Vector3f n(std::cos(lon), std::sin(lon), 0);
        bottom.push_back(add_vertex(m, p, Eigen::Vector3f(r * n.x(), r * n.y(), -hh), n, -1));
        top.push_back(add_vertex(m, p, Eigen::Vector3f(r * n.x(), r * n.y(), hh), n, -1));
      }
      for (int s = 0; s < segments; ++s) {
        const int s1 = (s + 1) % segments;
        const Eigen::Vector3f out = m.normals[bottom[s]] + m.normals[bottom[s1]];
        add_triangle(m, bottom[s], bottom[s1], top[s1], out);
        add_triangle(m, bottom[s], top[s1], top[s], out);
      }
      for (float sign : {-1.0f, 1.0f}) {
        const Eigen::Vector3f n(0, 0, sign);
        const uint32_t centre = add_vertex(m, p, Eigen::Vector3f(0, 0, sign * hh), n, 2);
        std::vector<uint32_t> ring;
        for (int s = 0; s < segments; ++s) {
          const float lon = two_pi * s / segments;
          ring.push_back(add_vertex(m, p, Eigen::Vector3f(r * std::cos(lon), r * std::sin(lon), sign * hh), n, 2));
        }
        for (int s = 0; s < segments; ++s) add_triangle(m, centre, ring[s], ring[(s + 1) % segments], n);
      }
      break;
    }
  }
  return m;
}

}  // namespace cofusion::synthetic
