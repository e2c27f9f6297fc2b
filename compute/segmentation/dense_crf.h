#pragma once
// Fully connected CRF over superpixels with Potts compatibility and two Gaussian kernels, solved
// by mean-field inference (Krähenbühl & Koltun 2011), as Co-Fusion's segmentation does:
//   appearance k_a = exp(-|p_i-p_j|^2/2sa^2 - |c_i-c_j|^2/2sc^2 - (d_i-d_j)^2/2sd^2)
//   smoothness k_s = exp(-|p_i-p_j|^2/2ss^2)
// Each kernel is normalised symmetrically, k~(i,j) = k(i,j)/sqrt(D_i D_j) with D_i = sum_j k(i,j)
// (j = i included), as densecrf's NORMALIZE_SYMMETRIC which Co-Fusion uses; the message to node i
// for label l is sum_m w_m sum_j k~_m(i,j) Q_j(l), self term included as in that code.
#include <cstdint>
#include <span>
#include <vector>

#include "segmentation/permutohedral.h"

namespace cofusion::segmentation {

// One CRF node (a superpixel): position in grid units (pixels / grid step), mean RGB (0..255)
// and mean depth (metres).
struct CrfNode {
  float x = 0, y = 0;
  float r = 0, g = 0, b = 0;
  float depth_m = 0;
};

enum class CrfMethod {
  kExact,          // explicit kernel over all pairs (values below exact_cutoff dropped)
  kPermutohedral,  // permutohedral-lattice filtering (approximate Gaussians)
  kAuto,           // exact where the job system has kExactMinThreads threads or more, else the lattice
};

// The lattice's filtering hardly runs in parallel at Co-Fusion's 1200 nodes, the exact method's
// kernels do (fixed chunks of nodes). Measured in the pipeline (five_objects, 7 labels, median
// ms per frame): 2 threads (the dev machine) lattice 4.4, exact 5.2; 4 threads (a 16-core Xeon
// host limited by taskset) 5.6 and 5.3; 16 threads 6.3-8.8 and 3.5-3.8 (docs/experiments.md).
constexpr int kExactMinThreads = 4;
// The method kAuto stands for with `threads` threads (the others stand for themselves).
CrfMethod effective_method(CrfMethod method, int threads);

struct CrfParams {
  int iterations = 10;  // mean-field iterations
  // Appearance kernel (Co-Fusion's defaults): weight, and sigmas of colour (RGB levels 0..255),
  // depth (metres) and position (grid units: superpixel grid steps).
  float appearance_weight = 7.0f;
  float sigma_colour = 10.0f;
  float sigma_depth_m = 0.9f;
  float sigma_position = 1.8f;
  // Smoothness kernel: weight and position sigma (grid units; Co-Fusion's 2).
  float smoothness_weight = 2.0f;
  float sigma_smoothness = 2.0f;
  // Inference method (kAuto: by the job system's threads, above). Measured on the 2-core dev
  // machine (AMD EPYC VM), set-up + 10 mean-field
  // iterations, 3 labels, nodes on a jittered grid, best of 10, milliseconds:
  //   nodes          1 thread: exact / permutohedral    2 threads: exact / permutohedral
  //    300 (20x15)            1.4 / 0.8                          1.3 / 0.8
  //   1200 (40x30)            7.8 / 3.3                          4.7 / 3.3
  //   4800 (80x60)           36.6 / 12.9                        18.2 / 12.4
  // The lattice is faster at Co-Fusion's 1200 superpixels on few threads (2.4x in CPU time, which
  // is what counts next to a CPU Vulkan driver) and the gap grows with the count; with many
  // threads the exact method is (above). Their labels agree (dense_crf_test.cpp). The lattice
  // stays the default on every machine so that a run's results do not depend on how many cores
  // it has (as every other parallel step's do not, detail::for_fixed_chunks); kAuto is a choice
  // (config "auto") for speed on many cores.
  CrfMethod method = CrfMethod::kPermutohedral;
  // Exact method: kernel values below this are dropped (pairs farther apart than
  // sqrt(-2 ln cutoff) sigmas in position; 1e-6 -> 5.3 sigma). 0 keeps every pair (O(S^2)).
  float exact_cutoff = 1e-6f;
};

// Keeps kernel storage and scratch buffers between frames; one thread at a time (uses TBB inside).
class DenseCrf {
 public:
  // Builds the two kernels for these nodes (once per frame). Throws cofusion::Error on bad params.
  void set_nodes(std::span<const CrfNode> nodes, const CrfParams& params);

  // out[i*L + l] = sum over kernels m of w_m sum_j k~_m(i,j) q[j*L + l] for L = label_count.
  void message(std::span<const float> q, int label_count, std::span<float> out) const;

  // Mean-field: unary energies (node-major, node_count x label_count; lower = more likely) ->
  // marginals q (same layout). Starts from softmax(-unary).
  void infer(std::span<const float> unary, int label_count, std::vector<float>& q) const;

  int node_count() const { return node_count_; }
  // Stored kernel entries of the exact method (for tests and timing reports).
  int64_t exact_entries() const { return static_cast<int64_t>(columns_.size()); }

 private:
  // The exact kernels' bucket grid over node positions (grid steps).
  struct Buckets {
    int bw = 1, bh = 1, reach = 0;  // buckets across and down; buckets scanned each side
    bool all_pairs = false;         // exact_cutoff <= 0: every node is every node's neighbour
    float r2 = 0;                   // squared neighbour radius
    float x_min = 0, x_max = 0, y_min = 0, y_max = 0;
  };
  void set_permutohedral(std::span<const CrfNode> nodes);
  Buckets sort_into_buckets(std::span<const CrfNode> nodes);
  template <typename Fn>
  void for_neighbours(const Buckets& g, size_t i, float xi, float yi, Fn&& fn) const;
  void build_exact_kernels(std::span<const CrfNode> nodes, const Buckets& g);
  void normalise_exact_kernels();
  template <int kStride>
  void exact_message(const float* q, float* out, size_t stride) const;

  CrfParams params_;
  int node_count_ = 0;
  // Exact: combined normalised kernel in CSR form (row i: [row_begin_[i], row_begin_[i+1])).
  std::vector<int64_t> row_begin_;
  std::vector<int32_t> columns_;
  std::vector<float> values_;
  // Permutohedral: a 6-D appearance lattice and a 2-D smoothness lattice with their normalisers.
  PermutohedralLattice appearance_, smoothness_;
  std::vector<float> norm_appearance_, norm_smoothness_;
  mutable std::vector<float> scaled_, filtered_, message_;
  mutable std::vector<float> scaled_smoothness_, filtered_smoothness_;  // the lattice's second filter
  // Exact-kernel construction scratch, kept so that frames do not reallocate (page faults).
  struct ExactChunk {
    std::vector<int32_t> columns;
    std::vector<float> arg_a, arg_s;  // exponents of the two kernels
  };
  std::vector<ExactChunk> chunks_;
  std::vector<float> smooth_, norm_a_, norm_s_, bucket_x_, bucket_y_;
  std::vector<int32_t> bucket_of_, bucket_begin_, bucket_nodes_, bucket_fill_;
};

}  // namespace cofusion::segmentation
