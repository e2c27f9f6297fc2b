#include "eval/reconstruction_metrics.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <numbers>
#include <random>

#include "common/error.h"

namespace cofusion::eval {
namespace {

TriangleMesh unit_cube() {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  // Two triangles per face (x=0, x=1, y=0, y=1, z=0, z=1).
  const int faces[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
  for (const auto& f : faces) {
    m.triangles.emplace_back(f[0], f[1], f[2]);
    m.triangles.emplace_back(f[0], f[2], f[3]);
  }
  return m;
}

// Exact distance to the surface of the unit cube, from its definition.
double cube_surface_distance(const Eigen::Vector3d& p) {
  const Eigen::Vector3d outside = (p - Eigen::Vector3d::Ones()).cwiseMax(-p).cwiseMax(0.0);
  if (outside.squaredNorm() > 0) return outside.norm();
  return std::min(p.minCoeff(), (Eigen::Vector3d::Ones() - p).minCoeff());
}

// UV sphere of radius r with `rings` x `segments` quads (two triangles each, fans at the poles).
TriangleMesh uv_sphere(double r, int rings, int segments) {
  TriangleMesh m;
  for (int i = 0; i <= rings; ++i) {
    const double theta = std::numbers::pi * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double phi = 2 * std::numbers::pi * j / segments;
      m.vertices.emplace_back(r * std::sin(theta) * std::cos(phi), r * std::sin(theta) * std::sin(phi), r * std::cos(theta));
    }
  }
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const int a = i * segments + j, b = i * segments + (j + 1) % segments;
      const int c = (i + 1) * segments + j, d = (i + 1) * segments + (j + 1) % segments;
      m.triangles.emplace_back(a, c, d);
      m.triangles.emplace_back(a, d, b);
    }
  return m;
}

double brute_force_distance(const TriangleMesh& m, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d q = closest_point_on_triangle(p, m.vertices[static_cast<std::size_t>(t[0])],
                                                        m.vertices[static_cast<std::size_t>(t[1])],
                                                        m.vertices[static_cast<std::size_t>(t[2])]);
    best = std::min(best, (q - p).norm());
  }
  return best;
}

TEST(ClosestPointOnTriangle, MatchesDenseSamplingOnRandomTriangles) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  constexpr int kSteps = 300;
  for (int trial = 0; trial < 40; ++trial) {
    const Eigen::Vector3d a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
    const Eigen::Vector3d p = 2 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    const Eigen::Vector3d q = closest_point_on_triangle(p, a, b, c);
    // q lies on the triangle: barycentric coordinates in [0, 1].
    const Eigen::Vector3d n = (b - a).cross(c - a);
    EXPECT_NEAR((q - a).dot(n.normalized()), 0.0, 1e-12);
    double sampled = std::numeric_limits<double>::infinity();
    for (int i = 0; i <= kSteps; ++i)
      for (int j = 0; i + j <= kSteps; ++j) {
        const Eigen::Vector3d s = a + (b - a) * (double(i) / kSteps) + (c - a) * (double(j) / kSteps);
        sampled = std::min(sampled, (s - p).norm());
      }
    const double exact = (q - p).norm();
    const double spacing = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()}) / kSteps;
    EXPECT_LE(exact, sampled + 1e-12);
    EXPECT_GE(exact, sampled - spacing);
  }
}

TEST(ClosestPointOnTriangle, DegenerateTriangles) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(2, 0, 0);  // collinear
  EXPECT_NEAR((closest_point_on_triangle(Eigen::Vector3d(1.5, 1, 0), a, b, c) - Eigen::Vector3d(1.5, 0, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR((closest_point_on_triangle(Eigen::Vector3d(3, 0, 0), a, b, c) - c).norm(), 0, 1e-12);
  // A point triangle.
  EXPECT_NEAR((closest_point_on_triangle(Eigen::Vector3d(1, 1, 1), a, a, a) - a).norm(), 0, 1e-12);
}

TEST(MeshDistance, UnitCubeKnownDistances) {
  const MeshDistance cube(unit_cube());
  struct Case {
    Eigen::Vector3d p;
    double d;
  };
  const Case cases[] = {
      {{0.5, 0.5, 1.3}, 0.3},                          // outside, above a face
      {{0.5, 0.5, 0.5}, 0.5},                          // centre
      {{0.2, 0.5, 0.6}, 0.2},                          // inside, nearest face x = 0
      {{0.3, 0.0, 0.7}, 0.0},                          // on a face
      {{1.1, 0.5, 1.2}, std::sqrt(0.01 + 0.04)},       // outside, nearest an edge
      {{1.1, 1.2, -0.2}, 0.3},                         // outside, nearest a corner
      {{1.0, 1.0, 1.0}, 0.0},                          // a corner itself
      {{0.5, -0.25, 0.5}, 0.25},                       // below a face diagonal's midpoint
      {{-2.0, 3.0, 0.5}, std::sqrt(4.0 + 4.0)},        // far, nearest an edge
  };
  for (const auto& c : cases) EXPECT_NEAR(cube.distance(c.p), c.d, 1e-12) << c.p.transpose();
  EXPECT_TRUE(cube.closest_point(Eigen::Vector3d(1.1, 1.2, -0.2)).isApprox(Eigen::Vector3d(1, 1, 0), 1e-12));
}

TEST(MeshDistance, AgreesWithAnalyticCubeAndBruteForceOnRandomPoints) {
  const TriangleMesh mesh = unit_cube();
  const MeshDistance cube(mesh);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 2.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 2000; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  const std::vector<double> d = cube.distances(points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(d[i], cube_surface_distance(points[i]), 1e-12) << points[i].transpose();
    EXPECT_NEAR(d[i], brute_force_distance(mesh, points[i]), 1e-12);
  }
}

TEST(MeshDistance, BvhEqualsBruteForceOnSphere) {
  const TriangleMesh sphere = uv_sphere(0.5, 40, 60);  // 4800 triangles
  const MeshDistance bvh(sphere);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  std::uniform_real_distribution<double> radius(0.0, 1.5);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d p = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized() * radius(rng);
    EXPECT_NEAR(bvh.distance(p), brute_force_distance(sphere, p), 1e-12) << p.transpose();
  }
}

TEST(MeshDistance, RejectsBadMeshes) {
  EXPECT_THROW(MeshDistance(TriangleMesh{}), Error);
  TriangleMesh bad = unit_cube();
  bad.triangles.emplace_back(0, 1, 8);
  EXPECT_THROW(MeshDistance{bad}, Error);
}

TEST(ReconstructionErrors, StatisticsAndOutlierShares) {
  const MeshDistance cube(unit_cube());
  // Distances 0.0, 0.005, 0.02, 0.1 above the top face.
  const std::vector<Eigen::Vector3d> points = {{0.5, 0.5, 1.0}, {0.5, 0.5, 1.005}, {0.5, 0.5, 1.02}, {0.5, 0.5, 1.1}};
  const ReconstructionErrors r = compute_reconstruction_errors(points, cube);
  EXPECT_EQ(r.distance_m.count, 4u);
  EXPECT_NEAR(r.distance_m.mean, (0.0 + 0.005 + 0.02 + 0.1) / 4, 1e-12);
  EXPECT_NEAR(r.distance_m.median, (0.005 + 0.02) / 2, 1e-12);
  EXPECT_NEAR(r.distance_m.max, 0.1, 1e-12);
  ASSERT_EQ(r.share_above.size(), 2u);
  EXPECT_DOUBLE_EQ(r.share_above[0], 0.5);   // > 1 cm
  EXPECT_DOUBLE_EQ(r.share_above[1], 0.25);  // > 5 cm
  EXPECT_THROW(compute_reconstruction_errors({}, cube), Error);
}

TEST(ReconstructionErrors, TransformAppliedFirst) {
  const MeshDistance cube(unit_cube());
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(0, 0, 10);
  const std::vector<Eigen::Vector3d> points = {{0.5, 0.5, -9.0}};
  EXPECT_NEAR(compute_reconstruction_errors(transform_points(points, T), cube).distance_m.mean, 0.0, 1e-12);
}

TEST(MeshDistance, MillionPointsHundredThousandTrianglesSlow) {
  const double r = 1.0;
  const TriangleMesh sphere = uv_sphere(r, 224, 224);  // 100352 triangles
  const auto start = std::chrono::steady_clock::now();
  const MeshDistance bvh(sphere);
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0, 1), noise(0, 0.01);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 1000000; ++i) points.push_back(Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized() * (r + noise(rng)));
  const std::vector<double> d = bvh.distances(points);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("1M points x %zu triangles: %.2f s\n", sphere.triangles.size(), seconds);
  // The tessellation lies within r (1 - cos(pi / 224)) ~ 1e-4 of the sphere.
  for (std::size_t i = 0; i < points.size(); i += 997) EXPECT_NEAR(d[i], std::abs(points[i].norm() - r), 2e-4);
  EXPECT_LT(seconds, 60.0);
}

}  // namespace
}  // namespace cofusion::eval
