#pragma once
// Permutohedral lattice (Adams, Baek & Davis 2010) for Gaussian filtering in d dimensions, as used
// by Krähenbühl & Koltun (2011) for mean-field inference in fully connected CRFs: splat every
// point onto the d+1 vertices of its enclosing simplex, blur along the d+1 lattice directions with
// [1/2 1 1/2], slice back. Filtering n points costs O(n d^2 + vertices d), independent of sigma.
#include <cstdint>
#include <vector>

namespace cofusion::segmentation {

class PermutohedralLattice {
 public:
  // features: n points x d values (point-major), each already divided by its kernel sigma so the
  // filter approximates exp(-|f_i - f_j|^2 / 2). Builds the lattice (in parallel; the vertices
  // are numbered as one pass over the points would, so the result is the same for any split).
  void init(const float* features, int d, int n);

  // out[i*v + c] ~= sum_j exp(-|f_i - f_j|^2 / 2) in[j*v + c] (including j = i), for v values per
  // point. in and out are n*v floats and must not alias. The channels run side by side in groups
  // where the job system has threads to spare; the output is the same for any grouping. One call
  // at a time per lattice (it keeps scratch buffers).
  void filter(const float* in, float* out, int v) const;

  int dimensions() const { return d_; }
  int points() const { return n_; }
  int vertices() const { return vertex_count_; }

 private:
  struct Scratch {
    std::vector<float> values, blurred;  // (vertices + 1) x the group's channels
  };
  // filter() for channels [c0, c1) of every point's v values.
  void filter_channels(const float* in, float* out, int v, int c0, int c1, Scratch& s) const;

  int d_ = 0, n_ = 0, vertex_count_ = 0;
  std::vector<int32_t> offset_;     // n*(d+1): lattice vertex of each simplex corner
  std::vector<float> barycentric_;  // n*(d+1): its weight
  std::vector<int32_t> neighbour_;  // vertices*(d+1)*2: the two neighbours along each direction (absent: vertices)
  std::vector<int32_t> keys_;       // n*(d+1)*d: init()'s simplex corners' keys (kept: no allocation per frame)
  mutable std::vector<Scratch> group_scratch_;
};

}  // namespace cofusion::segmentation
