#pragma once
// How much of a surfel map is redundant (issue 22: "a map that grows with the surface, not with
// time"): the share of surfels that duplicate a neighbour, and the share that were never confirmed.
//
// A surfel i is a duplicate when another surfel j lies within radius_fraction * radius_i of it
// (3D distance, metres) with a normal within max_normal_angle_deg of i's. Both members of a
// duplicated pair count. Neighbours are found through a uniform grid (cell = the median search
// radius); queries run in parallel (oneTBB).
#include <Eigen/Core>
#include <cstddef>
#include <filesystem>
#include <span>
#include <vector>

namespace cofusion::eval {

struct MapSurfel {
  Eigen::Vector3f position_m;
  Eigen::Vector3f normal;  // unit
  float radius_m = 0;
  float confidence = 0;
};

struct DuplicateParams {
  // A neighbour within this fraction of the surfel's own radius (m per m) ...
  double radius_fraction = 0.5;
  // ... whose normal is within this angle (degrees) makes the surfel a duplicate.
  double max_normal_angle_deg = 35.0;
  // Surfels below this confidence (accumulated fusion weight) are counted as unconfirmed.
  double low_confidence = 2.0;
};

struct SurfelMapStats {
  std::size_t surfels = 0;
  std::size_t duplicates = 0;
  double duplicate_share = 0;       // duplicates / surfels (0 for an empty map)
  double low_confidence_share = 0;  // share with confidence < params.low_confidence
};

// Per surfel: whether it is a duplicate (see above).
std::vector<bool> find_duplicates(std::span<const MapSurfel> surfels, const DuplicateParams& params = {});
SurfelMapStats compute_surfel_map_stats(std::span<const MapSurfel> surfels, const DuplicateParams& params = {});

// Surfels of a model PLY as `cofusion run` writes it (x y z nx ny nz radius confidence vertex
// properties). Throws cofusion::Error naming the file on a missing property or a bad file.
std::vector<MapSurfel> read_ply_surfels(const std::filesystem::path& path);

}  // namespace cofusion::eval
