#pragma once
// Reconstruction error as in the Co-Fusion paper (Sec. VI "Fusion", Table I): for every surfel
// (point) of the model, the distance to the closest point of the ground-truth meshes after the two
// are put in one frame; reported as mean / std / median and the share of points farther than
// 1 cm and 5 cm ("outliers").
//
// Distances are exact point-to-triangle distances (double precision) found through a bounding
// volume hierarchy over the triangles; queries run in parallel (oneTBB).
#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "eval/error_stats.h"
#include "eval/geometry_io.h"
#include "io/frame.h"

namespace cofusion::eval {

// Closest point of triangle (a, b, c) to p; degenerate (zero-area) triangles are handled as their
// longest edge. Exposed for tests.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c);

// Nearest-surface queries against a fixed triangle mesh. Thread-safe for concurrent queries.
class MeshDistance {
 public:
  // Throws cofusion::Error when the mesh has no triangles or an index is out of range.
  explicit MeshDistance(const TriangleMesh& mesh);
  ~MeshDistance();
  MeshDistance(MeshDistance&&) noexcept;
  MeshDistance& operator=(MeshDistance&&) noexcept;

  // Unsigned distance (m) from p to the closest point of any triangle.
  double distance(const Eigen::Vector3d& p) const;
  Eigen::Vector3d closest_point(const Eigen::Vector3d& p) const;
  // One distance per point, computed in parallel.
  std::vector<double> distances(std::span<const Eigen::Vector3d> points) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct ReconstructionParams {
  std::vector<double> outlier_thresholds_m = {0.01, 0.05};  // Table I: "Outlier-1cm", "Outlier-5cm"
};

struct ReconstructionErrors {
  ErrorStats distance_m;
  std::vector<double> thresholds_m;        // = params.outlier_thresholds_m
  std::vector<double> share_above;         // fraction (0..1) of points with distance > threshold
  std::vector<double> distances_m;         // per point, input order
};

// Throws cofusion::Error when there are no points.
ReconstructionErrors compute_reconstruction_errors(std::span<const Eigen::Vector3d> points, const MeshDistance& mesh,
                                                   const ReconstructionParams& params = {});

// Applies T to every point (e.g. T_gt_model, mapping model coordinates into the mesh's frame).
std::vector<Eigen::Vector3d> transform_points(std::span<const Eigen::Vector3d> points, const Pose& T);

}  // namespace cofusion::eval
