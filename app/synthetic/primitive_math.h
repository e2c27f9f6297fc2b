#pragma once
// Per-pixel math of the synthetic renderer, in float and inline (the renderer calls it for every
// pixel and primitive): ray intersection and surface normals of the analytic shapes in their own
// frames, and the procedural solid textures. Shapes are centred on their origin: a box spans
// [-half, half]; a cylinder has its axis along z; a room is a box seen from the inside.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "synthetic/scene.h"

namespace cofusion::synthetic {

enum class PrimitiveKind : uint8_t { kBox, kSphere, kCylinder, kRoom };

// Shape parameters in float, as the renderer's inner loop uses them.
struct ShapeF {
  PrimitiveKind kind = PrimitiveKind::kBox;
  Eigen::Vector3f half_extents{0, 0, 0};
  float radius = 0;
  float half_height = 0;
};

namespace detail {

// Slab test against [-h, h]: entry and exit parameters of the ray's line.
inline void slabs(const Eigen::Vector3f& h, const Eigen::Vector3f& o, const Eigen::Vector3f& d, float& t_near,
                  float& t_far) {
  t_near = -std::numeric_limits<float>::infinity();
  t_far = std::numeric_limits<float>::infinity();
  for (int i = 0; i < 3; ++i) {
    const float inv = 1.0f / d[i];
    float ta = (-h[i] - o[i]) * inv, tb = (h[i] - o[i]) * inv;
    if (ta > tb) std::swap(ta, tb);
    t_near = ta > t_near ? ta : t_near;
    t_far = tb < t_far ? tb : t_far;
  }
}

// Roots of a t^2 + 2 b t + c = 0, near first, in the numerically stable form.
inline bool quadratic(float a, float b, float c, float& t0, float& t1) {
  const float disc = b * b - a * c;
  if (disc < 0 || a <= 0) return false;
  const float q = -(b + std::copysign(std::sqrt(disc), b));
  if (q == 0) return false;
  t0 = q / a;
  t1 = c / q;
  if (t0 > t1) std::swap(t0, t1);
  return true;
}

}  // namespace detail

// Nearest intersection of o + t d with t in (t_min, t_max) in the primitive frame, or false.
inline bool intersect(const ShapeF& s, const Eigen::Vector3f& o, const Eigen::Vector3f& d, float t_min,
                      float t_max, float& t_out) {
  switch (s.kind) {
    case PrimitiveKind::kBox: {
      float tn, tf;
      detail::slabs(s.half_extents, o, d, tn, tf);
      if (tn > tf || tn <= t_min || tn >= t_max) return false;  // tn <= t_min: camera inside, not drawn
      t_out = tn;
      return true;
    }
    case PrimitiveKind::kRoom: {
      float tn, tf;
      detail::slabs(s.half_extents, o, d, tn, tf);
      if (tn > tf || tf <= t_min || tf >= t_max) return false;
      t_out = tf;
      return true;
    }
    case PrimitiveKind::kSphere: {
      float t0, t1;
      if (!detail::quadratic(d.dot(d), o.dot(d), o.dot(o) - s.radius * s.radius, t0, t1)) return false;
      if (t0 <= t_min || t0 >= t_max) return false;  // t0 <= t_min: camera inside, not drawn
      t_out = t0;
      return true;
    }
    case PrimitiveKind::kCylinder: {
      float best = t_max;
      bool hit = false;
      // Side: (ox + t dx)^2 + (oy + t dy)^2 = r^2 with |z| <= half_height.
      float t0, t1;
      const float a = d.x() * d.x() + d.y() * d.y();
      if (a > 0 && detail::quadratic(a, o.x() * d.x() + o.y() * d.y(),
                             o.x() * o.x() + o.y() * o.y() - s.radius * s.radius, t0, t1)) {
        if (t0 > t_min && t0 < best && std::abs(o.z() + t0 * d.z()) <= s.half_height) {
          best = t0;
          hit = true;
        }
      }
      // Caps.
      if (d.z() != 0) {
        for (float zc : {-s.half_height, s.half_height}) {
          const float t = (zc - o.z()) / d.z();
          if (t > t_min && t < best) {
            const float x = o.x() + t * d.x(), y = o.y() + t * d.y();
            if (x * x + y * y <= s.radius * s.radius) {
              best = t;
              hit = true;
            }
          }
        }
      }
      if (hit) t_out = best;
      return hit;
    }
  }
  return false;
}

// Outward unit normal (inward for a room) at a surface point of the shape, and the axis the face is
// perpendicular to (box, room, cylinder caps) or -1 (sphere, cylinder side).
inline void surface_at(const ShapeF& s, const Eigen::Vector3f& p, Eigen::Vector3f& normal, int& flat_axis) {
  switch (s.kind) {
    case PrimitiveKind::kBox:
    case PrimitiveKind::kRoom: {
      int axis = 0;
      float best = -1;
      for (int i = 0; i < 3; ++i) {
        const float r = std::abs(p[i]) / s.half_extents[i];
        if (r > best) {
          best = r;
          axis = i;
        }
      }
      normal = Eigen::Vector3f::Zero();
      const float sign = p[axis] >= 0 ? 1.0f : -1.0f;
      normal[axis] = s.kind == PrimitiveKind::kRoom ? -sign : sign;
      flat_axis = axis;
      return;
    }
    case PrimitiveKind::kSphere:
      normal = p.normalized();
      flat_axis = -1;
      return;
    case PrimitiveKind::kCylinder: {
      const float radial = std::sqrt(p.x() * p.x() + p.y() * p.y());
      if (std::abs(s.half_height - std::abs(p.z())) < std::abs(s.radius - radial)) {
        normal = Eigen::Vector3f(0, 0, p.z() >= 0 ? 1.0f : -1.0f);
        flat_axis = 2;
      } else {
        normal = radial > 0 ? Eigen::Vector3f(p.x() / radial, p.y() / radial, 0) : Eigen::Vector3f(1, 0, 0);
        flat_axis = -1;
      }
      return;
    }
  }
}

namespace detail {

// Lattice of pseudo-random values for the noise texture, fixed at compile time (Perlin-style
// permutation, doubled so that perm[perm[x] + y] needs no wrap).
struct NoiseLattice {
  std::array<uint8_t, 512> perm{};
  std::array<float, 256> value{};
};

constexpr NoiseLattice make_lattice() {
  NoiseLattice l;
  uint64_t state = 0x2545F4914F6CDD1Dull;
  auto next = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<uint32_t>(state >> 33);
  };
  std::array<uint8_t, 256> p{};
  for (int i = 0; i < 256; ++i) p[i] = static_cast<uint8_t>(i);
  for (int i = 255; i > 0; --i) {
    const int j = static_cast<int>(next() % static_cast<uint32_t>(i + 1));
    const uint8_t t = p[i];
    p[i] = p[j];
    p[j] = t;
  }
  for (int i = 0; i < 512; ++i) l.perm[i] = p[i & 255];
  for (int i = 0; i < 256; ++i) l.value[i] = static_cast<float>(next() % 65536u) / 65535.0f;
  return l;
}

constexpr NoiseLattice kLattice = make_lattice();

inline float lattice(int x, int y, int z) {
  return kLattice.value[kLattice.perm[kLattice.perm[kLattice.perm[x & 255] + (y & 255)] + (z & 255)]];
}

// Trilinearly interpolated lattice noise in [0, 1] with smoothstep weights.
inline float value_noise(const Eigen::Vector3f& q) {
  const float fx = std::floor(q.x()), fy = std::floor(q.y()), fz = std::floor(q.z());
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy), iz = static_cast<int>(fz);
  auto smooth = [](float t) { return t * t * (3 - 2 * t); };
  const float ux = smooth(q.x() - fx), uy = smooth(q.y() - fy), uz = smooth(q.z() - fz);
  auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
  const float x00 = lerp(lattice(ix, iy, iz), lattice(ix + 1, iy, iz), ux);
  const float x10 = lerp(lattice(ix, iy + 1, iz), lattice(ix + 1, iy + 1, iz), ux);
  const float x01 = lerp(lattice(ix, iy, iz + 1), lattice(ix + 1, iy, iz + 1), ux);
  const float x11 = lerp(lattice(ix, iy + 1, iz + 1), lattice(ix + 1, iy + 1, iz + 1), ux);
  return lerp(lerp(x00, x10, uy), lerp(x01, x11, uy), uz);
}

}  // namespace detail

// Colour (0..255 per channel, unshaded) of a solid texture at a surface point in the shape's frame.
// flat_axis: the coordinate along the face normal is ignored on flat faces, so faces that sit on a
// texture cell boundary do not flicker.
inline Eigen::Vector3f texture_color(const TextureDesc& texture, const Eigen::Vector3f& point, int flat_axis) {
  const TextureDesc* tex = &texture;
  Eigen::Vector3f q = point;  // solid texture: the colour is a function of the point in 3-D
  if (flat_axis >= 0) q[flat_axis] = 0;
  const float inv_scale = 1.0f / static_cast<float>(tex->scale_m);
  switch (tex->type) {
    case TextureType::kSolid: return tex->colors[0];
    case TextureType::kChecker: {
      const long parity = static_cast<long>(std::floor(q.x() * inv_scale)) +
                          static_cast<long>(std::floor(q.y() * inv_scale)) +
                          static_cast<long>(std::floor(q.z() * inv_scale));
      return tex->colors[parity & 1];
    }
    case TextureType::kStripes: {
      const long i = static_cast<long>(std::floor(q[tex->axis] * inv_scale));
      return tex->colors[i & 1];
    }
    case TextureType::kNoise: {
      const Eigen::Vector3f s = q * inv_scale;
      // Two octaves; the second is offset so the lattices do not line up.
      const float n = 0.65f * detail::value_noise(s) +
                      0.35f * detail::value_noise(2.03f * s + Eigen::Vector3f(17.1f, 3.3f, 9.7f));
      return tex->colors[0] + (tex->colors[1] - tex->colors[0]) * n;
    }
  }
  return tex->colors[0];
}

}  // namespace cofusion::synthetic
