#include "eval/reconstruction_metrics.h"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <limits>
#include <numeric>
#include <string>

#include "common/error.h"

namespace cofusion::eval {
namespace {

Eigen::Vector3d closest_point_on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  if (len2 <= 0) return a;
  const double t = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
  return a + t * ab;
}

}  // namespace

// Region-based closest point (Ericson, Real-Time Collision Detection, 5.1.5): test the vertex
// regions, then the edge regions, else project onto the face.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a;
  const double area2 = ab.cross(ac).squaredNorm();
  const double scale2 = std::max({ab.squaredNorm(), ac.squaredNorm(), (c - b).squaredNorm()});
  if (area2 <= 1e-24 * scale2 * scale2) {
    // Degenerate: the closest of the three edges.
    const std::array<Eigen::Vector3d, 3> q = {closest_point_on_segment(p, a, b), closest_point_on_segment(p, b, c),
                                             closest_point_on_segment(p, c, a)};
    std::size_t best = 0;
    for (std::size_t i = 1; i < 3; ++i)
      if ((q[i] - p).squaredNorm() < (q[best] - p).squaredNorm()) best = i;
    return q[best];
  }
  const Eigen::Vector3d ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// Binary BVH with median splits on the longest axis of the centroid bounds; leaves hold up to
// kLeafSize triangles, stored contiguously in BVH order.
struct MeshDistance::Impl {
  static constexpr int kLeafSize = 4;
  struct Node {
    Eigen::AlignedBox3d box;
    int left = -1, right = -1;  // children (inner node)
    int first = 0, count = 0;   // triangle range (leaf, count > 0)
  };
  std::vector<Node> nodes;
  std::vector<std::array<Eigen::Vector3d, 3>> tris;

  int build(std::vector<int>& order, const std::vector<Eigen::Vector3d>& centroids,
            const std::vector<std::array<Eigen::Vector3d, 3>>& source, int begin, int end) {
    const int index = static_cast<int>(nodes.size());
    nodes.emplace_back();
    Eigen::AlignedBox3d box, centroid_box;
    for (int i = begin; i < end; ++i) {
      const auto& t = source[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])];
      for (const auto& v : t) box.extend(v);
      centroid_box.extend(centroids[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])]);
    }
    nodes[static_cast<std::size_t>(index)].box = box;
    if (end - begin <= kLeafSize) {
      nodes[static_cast<std::size_t>(index)].first = static_cast<int>(tris.size());
      nodes[static_cast<std::size_t>(index)].count = end - begin;
      for (int i = begin; i < end; ++i) tris.push_back(source[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])]);
      return index;
    }
    int axis = 0;
    centroid_box.sizes().maxCoeff(&axis);
    const int mid = begin + (end - begin) / 2;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](int x, int y) {
      return centroids[static_cast<std::size_t>(x)][axis] < centroids[static_cast<std::size_t>(y)][axis];
    });
    const int left = build(order, centroids, source, begin, mid);
    const int right = build(order, centroids, source, mid, end);
    nodes[static_cast<std::size_t>(index)].left = left;
    nodes[static_cast<std::size_t>(index)].right = right;
    return index;
  }

  Eigen::Vector3d closest(const Eigen::Vector3d& p) const {
    double best_d2 = std::numeric_limits<double>::infinity();
    Eigen::Vector3d best = p;
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes[static_cast<std::size_t>(stack[--top])];
      if (node.box.squaredExteriorDistance(p) >= best_d2) continue;
      if (node.count > 0) {
        for (int i = node.first; i < node.first + node.count; ++i) {
          const auto& t = tris[static_cast<std::size_t>(i)];
          const Eigen::Vector3d q = closest_point_on_triangle(p, t[0], t[1], t[2]);
          const double d2 = (q - p).squaredNorm();
          if (d2 < best_d2) {
            best_d2 = d2;
            best = q;
          }
        }
        continue;
      }
      // Visit the nearer child first (pushed last).
      const double dl = nodes[static_cast<std::size_t>(node.left)].box.squaredExteriorDistance(p);
      const double dr = nodes[static_cast<std::size_t>(node.right)].box.squaredExteriorDistance(p);
      if (dl < dr) {
        if (dr < best_d2) stack[top++] = node.right;
        if (dl < best_d2) stack[top++] = node.left;
      } else {
        if (dl < best_d2) stack[top++] = node.left;
        if (dr < best_d2) stack[top++] = node.right;
      }
    }
    return best;
  }
};

MeshDistance::MeshDistance(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  if (mesh.triangles.empty()) throw Error("mesh distance: the mesh has no triangles");
  std::vector<std::array<Eigen::Vector3d, 3>> source;
  std::vector<Eigen::Vector3d> centroids;
  source.reserve(mesh.triangles.size());
  const auto n_vertices = static_cast<int>(mesh.vertices.size());
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k)
      if (t[k] < 0 || t[k] >= n_vertices)
        throw Error("mesh distance: vertex index " + std::to_string(t[k]) + " out of range (" + std::to_string(n_vertices) +
                    " vertices)");
    const std::array<Eigen::Vector3d, 3> tri = {mesh.vertices[static_cast<std::size_t>(t[0])],
                                                mesh.vertices[static_cast<std::size_t>(t[1])],
                                                mesh.vertices[static_cast<std::size_t>(t[2])]};
    for (const auto& v : tri)
      if (!v.allFinite()) throw Error("mesh distance: the mesh has a non-finite vertex");
    source.push_back(tri);
    centroids.push_back((tri[0] + tri[1] + tri[2]) / 3.0);
  }
  std::vector<int> order(source.size());
  std::iota(order.begin(), order.end(), 0);
  // Median splits halve every range, so the depth (and the query stack) stays below log2(n) + 2.
  impl_->nodes.reserve(2 * source.size() / Impl::kLeafSize + 2);
  impl_->tris.reserve(source.size());
  impl_->build(order, centroids, source, 0, static_cast<int>(source.size()));
}

MeshDistance::~MeshDistance() = default;
MeshDistance::MeshDistance(MeshDistance&&) noexcept = default;
MeshDistance& MeshDistance::operator=(MeshDistance&&) noexcept = default;

Eigen::Vector3d MeshDistance::closest_point(const Eigen::Vector3d& p) const { return impl_->closest(p); }

double MeshDistance::distance(const Eigen::Vector3d& p) const { return (impl_->closest(p) - p).norm(); }

std::vector<double> MeshDistance::distances(std::span<const Eigen::Vector3d> points) const {
  std::vector<double> out(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 1024), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) out[i] = distance(points[i]);
  });
  return out;
}

ReconstructionErrors compute_reconstruction_errors(std::span<const Eigen::Vector3d> points, const MeshDistance& mesh,
                                                   const ReconstructionParams& params) {
  if (points.empty()) throw Error("reconstruction error: the model has no points");
  ReconstructionErrors out;
  out.distances_m = mesh.distances(points);
  out.distance_m = summarize_errors(out.distances_m);
  out.thresholds_m = params.outlier_thresholds_m;
  for (const double threshold : params.outlier_thresholds_m) {
    const auto above = std::count_if(out.distances_m.begin(), out.distances_m.end(), [&](double d) { return d > threshold; });
    out.share_above.push_back(static_cast<double>(above) / static_cast<double>(out.distances_m.size()));
  }
  return out;
}

std::vector<Eigen::Vector3d> transform_points(std::span<const Eigen::Vector3d> points, const Pose& T) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(points.size());
  for (const auto& p : points) out.push_back(T * p);
  return out;
}

}  // namespace cofusion::eval
