#include "eval/surfel_map_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "common/error.h"
#include "support/test_support.h"

namespace cofusion::eval {
namespace {

// A plane z = 0 of surfels on a grid of `spacing_m`, each with radius `radius_m`, normal +z.
std::vector<MapSurfel> grid_plane(int n, float spacing_m, float radius_m) {
  std::vector<MapSurfel> out;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      out.push_back({Eigen::Vector3f(x * spacing_m, y * spacing_m, 0), Eigen::Vector3f::UnitZ(), radius_m, 5.0f});
  return out;
}

TEST(SurfelMapMetrics, EmptyMapHasNoDuplicates) {
  const auto stats = compute_surfel_map_stats({});
  EXPECT_EQ(stats.surfels, 0u);
  EXPECT_EQ(stats.duplicate_share, 0.0);
}

TEST(SurfelMapMetrics, RegularGridHasNoDuplicates) {
  // Neighbours 5 mm apart, radius 7 mm: half the radius (3.5 mm) reaches none of them.
  const auto stats = compute_surfel_map_stats(grid_plane(50, 0.005f, 0.007f));
  EXPECT_EQ(stats.surfels, 2500u);
  EXPECT_EQ(stats.duplicates, 0u);
}

TEST(SurfelMapMetrics, CopiesNearbyWithSimilarNormalsAreDuplicates) {
  auto surfels = grid_plane(40, 0.005f, 0.007f);  // 1600
  const size_t originals = surfels.size();
  // Every 10th surfel gets a copy 1 mm away (within 3.5 mm; the next neighbour is 4 mm away) with a
  // normal 20 degrees off: both count.
  const float a = float(20.0 * M_PI / 180.0);
  for (size_t i = 0; i < originals; i += 10) {
    MapSurfel c = surfels[i];
    c.position_m += Eigen::Vector3f(0.001f, 0, 0);
    c.normal = Eigen::Vector3f(std::sin(a), 0, std::cos(a));
    c.confidence = 1.0f;
    surfels.push_back(c);
  }
  // Every 10th (offset 5) gets a copy nearby whose normal is 60 degrees off (another surface): no duplicate.
  const float b = float(60.0 * M_PI / 180.0);
  for (size_t i = 5; i < originals; i += 10) {
    MapSurfel c = surfels[i];
    c.position_m += Eigen::Vector3f(0, 0.001f, 0);
    c.normal = Eigen::Vector3f(0, std::sin(b), std::cos(b));
    surfels.push_back(c);
  }
  const auto stats = compute_surfel_map_stats(surfels);
  EXPECT_EQ(stats.surfels, originals + 320);
  EXPECT_EQ(stats.duplicates, 320u);
  EXPECT_NEAR(stats.duplicate_share, 320.0 / 1920.0, 1e-12);
  EXPECT_NEAR(stats.low_confidence_share, 160.0 / 1920.0, 1e-12);
}

TEST(SurfelMapMetrics, TheSearchRadiusIsTheSurfelsOwn) {
  // A large surfel (radius 4 cm) 1 cm from a small one (radius 5 mm): the large one has the small
  // one within half its radius, the small one does not have the large one within half of its.
  std::vector<MapSurfel> s = {{Eigen::Vector3f(0, 0, 1), Eigen::Vector3f::UnitZ(), 0.04f, 1},
                              {Eigen::Vector3f(0.01f, 0, 1), Eigen::Vector3f::UnitZ(), 0.005f, 1}};
  const auto dup = find_duplicates(s);
  EXPECT_TRUE(dup[0]);
  EXPECT_FALSE(dup[1]);
}

TEST(SurfelMapMetrics, ReadsTheRunsModelPly) {
  const auto dir = test::fresh_temp_dir("surfel_map_metrics");
  const auto path = dir / "model.ply";
  {
    std::ofstream f(path);
    f << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\n"
         "property uchar blue\nproperty float radius\nproperty float confidence\nend_header\n"
         "0 0 1 0 0 -1 10 20 30 0.01 3\n0.001 0 1 0 0 -1 10 20 30 0.01 1\n";
  }
  const auto surfels = read_ply_surfels(path);
  ASSERT_EQ(surfels.size(), 2u);
  EXPECT_FLOAT_EQ(surfels[1].radius_m, 0.01f);
  EXPECT_FLOAT_EQ(surfels[0].confidence, 3.0f);
  const auto stats = compute_surfel_map_stats(surfels);
  EXPECT_EQ(stats.duplicates, 2u);
  EXPECT_DOUBLE_EQ(stats.low_confidence_share, 0.5);
}

TEST(SurfelMapMetrics, APlyWithoutRadiusIsAnError) {
  const auto path = test::fresh_temp_dir("surfel_map_metrics") / "points.ply";
  {
    std::ofstream f(path);
    f << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n";
  }
  EXPECT_THROW(read_ply_surfels(path), Error);
}

}  // namespace
}  // namespace cofusion::eval
