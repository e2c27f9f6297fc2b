#include "eval/surfel_map_metrics.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>

#include "common/error.h"
#include "io/ply_reader.h"

namespace cofusion::eval {
namespace {

// Surfels sorted by grid cell, with the range of each occupied cell.
class SurfelGrid {
 public:
  SurfelGrid(std::span<const MapSurfel> surfels, float cell_m) : cell_m_(cell_m) {
    order_.reserve(surfels.size());
    for (std::size_t i = 0; i < surfels.size(); ++i) order_.emplace_back(key(cell_of(surfels[i].position_m)), i);
    std::sort(order_.begin(), order_.end());
    for (std::size_t n = 0; n < order_.size();) {
      std::size_t end = n;
      while (end < order_.size() && order_[end].first == order_[n].first) ++end;
      ranges_.emplace(order_[n].first, std::pair(n, end));
      n = end;
    }
  }
  Eigen::Vector3i cell_of(const Eigen::Vector3f& p_m) const {
    return (p_m / cell_m_).array().floor().cast<int>();
  }
  // Calls f(index) for every surfel in the cells within `reach` cells of `c`.
  template <class F>
  void for_each_near(const Eigen::Vector3i& c, int reach, F&& f) const {
    for (int dz = -reach; dz <= reach; ++dz)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dx = -reach; dx <= reach; ++dx) {
          const auto it = ranges_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == ranges_.end()) continue;
          for (std::size_t n = it->second.first; n < it->second.second; ++n) f(order_[n].second);
        }
  }

 private:
  static uint64_t key(const Eigen::Vector3i& c) {
    const auto part = [](int v) { return uint64_t(uint32_t(v) & 0x1FFFFFu); };
    return part(c.x()) | (part(c.y()) << 21) | (part(c.z()) << 42);
  }
  float cell_m_;
  std::vector<std::pair<uint64_t, std::size_t>> order_;
  std::unordered_map<uint64_t, std::pair<std::size_t, std::size_t>> ranges_;
};

float median_search_radius_m(std::span<const MapSurfel> surfels, double fraction) {
  std::vector<float> r;
  r.reserve(surfels.size());
  for (const auto& s : surfels) r.push_back(float(fraction) * s.radius_m);
  std::nth_element(r.begin(), r.begin() + std::ptrdiff_t(r.size() / 2), r.end());
  return r[r.size() / 2];
}

}  // namespace

std::vector<bool> find_duplicates(std::span<const MapSurfel> surfels, const DuplicateParams& params) {
  std::vector<bool> duplicate(surfels.size(), false);
  if (surfels.empty()) return duplicate;
  const float cell_m = std::max(median_search_radius_m(surfels, params.radius_fraction), 1e-4f);
  const SurfelGrid grid(surfels, cell_m);
  const float min_dot = float(std::cos(params.max_normal_angle_deg * M_PI / 180.0));
  std::vector<uint8_t> flags(surfels.size(), 0);  // vector<bool> is not safe to write in parallel
  tbb::parallel_for(std::size_t{0}, surfels.size(), [&](std::size_t i) {
    const MapSurfel& s = surfels[i];
    const float reach_m = float(params.radius_fraction) * s.radius_m;
    const int reach_cells = std::min(int(std::ceil(reach_m / cell_m)), 8);
    bool found = false;
    grid.for_each_near(grid.cell_of(s.position_m), reach_cells, [&](std::size_t j) {
      if (found || j == i) return;
      const MapSurfel& o = surfels[j];
      found = (o.position_m - s.position_m).squaredNorm() < reach_m * reach_m && o.normal.dot(s.normal) >= min_dot;
    });
    flags[i] = found ? 1 : 0;
  });
  for (std::size_t i = 0; i < surfels.size(); ++i) duplicate[i] = flags[i] != 0;
  return duplicate;
}

SurfelMapStats compute_surfel_map_stats(std::span<const MapSurfel> surfels, const DuplicateParams& params) {
  SurfelMapStats stats;
  stats.surfels = surfels.size();
  if (surfels.empty()) return stats;
  const auto duplicate = find_duplicates(surfels, params);
  stats.duplicates = std::size_t(std::count(duplicate.begin(), duplicate.end(), true));
  const auto low = std::count_if(surfels.begin(), surfels.end(),
                                 [&](const MapSurfel& s) { return s.confidence < params.low_confidence; });
  stats.duplicate_share = double(stats.duplicates) / double(surfels.size());
  stats.low_confidence_share = double(low) / double(surfels.size());
  return stats;
}

std::vector<MapSurfel> read_ply_surfels(const std::filesystem::path& path) {
  const std::vector<std::string> columns = {"x", "y", "z", "nx", "ny", "nz", "radius", "confidence"};
  const ply::VertexTable t = ply::read_vertices(path, columns);
  for (std::size_t c = 0; c < columns.size(); ++c)
    if (!t.present[c]) throw Error("PLY file " + path.string() + ": no vertex property '" + columns[c] + "' (not a surfel model?)");
  std::vector<MapSurfel> out(t.count);
  for (std::size_t n = 0; n < t.count; ++n) {
    MapSurfel& s = out[n];
    s.position_m = Eigen::Vector3f(float(t.at(n, 0)), float(t.at(n, 1)), float(t.at(n, 2)));
    s.normal = Eigen::Vector3f(float(t.at(n, 3)), float(t.at(n, 4)), float(t.at(n, 5)));
    s.radius_m = float(t.at(n, 6));
    s.confidence = float(t.at(n, 7));
  }
  return out;
}

}  // namespace cofusion::eval
