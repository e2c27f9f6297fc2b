#pragma once
// Co-Fusion's motion segmentation (paper, section "Motion segmentation"), on the CPU:
//   1. SLIC superpixels of the frame (needs only the frame: run it while the GPU tracks);
//   2. unaries per superpixel and label from the per-pixel ICP costs of every active model after
//      tracking, plus an outlier label that is cheap only where no model explains the motion;
//   3. a fully connected CRF over the superpixels (mean-field), hard labels by maximum marginal;
//   4. post-processing on the pixel labels: connected components, only the largest component of
//      each object label kept, small components removed.
#include <cstdint>
#include <span>
#include <vector>

#include "segmentation/connected_components.h"
#include "segmentation/dense_crf.h"
#include "segmentation/slic.h"

namespace cofusion::segmentation {

inline constexpr uint8_t kNoLabel = 255;
// Labels are uint8 with kNoLabel reserved: at most this many models (the outlier label is 253).
inline constexpr int kMaxModels = 253;

struct MotionSegmentationParams {
  SlicParams slic;

  // --- Unaries. Label energies are ICP costs divided by cost_scale_m (dimensionless). ---
  // ICP alignment cost that counts as one unit of energy, metres.
  float cost_scale_m = 0.01f;
  // A model "has geometry" in a superpixel when at least this fraction of the superpixel's pixels
  // with valid depth carry a cost for it (Co-Fusion: confidence 0.3 for the background, 0.4 for
  // others); otherwise its cost there is the paper's fixed cost below.
  float min_geometry_fraction = 0.3f;
  // Fixed cost where a model has no geometry: this fraction of the frame's depth range (max - min
  // valid depth; the paper's 1%), metres...
  float no_geometry_cost_fraction = 0.01f;
  // ...but at least this (metres), so a nearly flat frame does not make "no geometry" the cheapest...
  float no_geometry_cost_min_m = 0.005f;
  // ...and at most this (metres): below the cost at which the outlier label wins (1.5 cm with the
  // defaults), so a superpixel no model has seen yet (a deep frame: 1% of 4 m is 4 cm) never
  // becomes an outlier just for being unseen.
  float no_geometry_cost_max_m = 0.01f;
  // The same bound for models 1.. (objects; model 0 is the background). At the outlier crossover
  // (1.5 cm), so an object's model never wins a superpixel it has no geometry in by its unary:
  // having seen nothing there is no evidence that the pixel moves with the object, and below the
  // crossover a model took the pixels of a neighbouring object that started to move the same way
  // (five_objects: objects 2 and 4 were found after 12 and 11 frames instead of 4). An object's own
  // newly seen surfaces get their cost from the caller (MotionCostParams::unseen_surface_cost_m).
  float object_no_geometry_cost_max_m = 0.015f;
  // Outlier energy, after Co-Fusion's code: max(outlier_threshold - outlier_slope * E_best,
  // outlier_min_energy), E_best the lowest energy among the models WITH geometry in the
  // superpixel (0 when none has: a model without geometry is no evidence of motion, so unseen
  // areas stay with the models rather than becoming new objects). With the defaults the outlier
  // wins where the best model's cost exceeds 1.5 cm (3 / (1 + 1) * cost_scale_m).
  float outlier_threshold = 3.0f;
  float outlier_slope = 1.0f;
  float outlier_min_energy = 0.01f;

  // --- CRF (fully connected over superpixels; see dense_crf.h for the kernels and timings). ---
  CrfParams crf;

  // --- Post-processing. ---
  // Components (4-connected, per label) smaller than this many pixels are removed (kNoLabel).
  // 1000 px = 0.33% of a 640x480 frame, about 4 superpixels of 16x16.
  int min_component_px = 1000;
  // An object's one component (its largest) is removed only below this many pixels: it is the
  // tracked object, not a candidate, and where the object leaves the view at the image's edge it is
  // a sliver of a few hundred pixels (handover's arm: 749, then 116). Below this it is noise.
  int min_object_component_px = 64;
};

struct SegmentationResult {
  int width = 0, height = 0;
  int model_count = 0;
  // Per pixel (row-major): 0..model_count-1 = model index (order of the `costs` given to
  // segment()), model_count = outlier, kNoLabel = no valid depth, or removed by post-processing.
  std::vector<uint8_t> labels;
  struct Component {
    uint8_t label = 0;
    int pixels = 0;
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // bounding box [x0, x1) x [y0, y1), pixels
  };
  // Connected outlier regions kept (each a candidate new model), largest first.
  std::vector<Component> outlier_components;
  std::vector<int> model_pixels;  // per model index, pixels labelled with it
  int superpixel_count = 0;       // superpixels given to segment()
  int crf_node_count = 0;         // superpixels with valid depth (the CRF's nodes)
  float depth_range_m = 0;        // max - min valid depth of the frame
  // Wall time of each step, milliseconds. slic_ms and prepare_ms (the CRF's nodes and kernels)
  // are of the superpixels() call that made the superpixels; where segment() prepared them itself,
  // prepare_ms is 0 and that time is part of unary_ms.
  double slic_ms = 0, prepare_ms = 0, unary_ms = 0, crf_ms = 0, post_ms = 0;

  uint8_t outlier_label() const { return static_cast<uint8_t>(model_count); }
};

// Keeps scratch buffers between frames; one thread at a time (uses TBB inside). Deterministic:
// the same input gives the same output whatever the thread count.
class MotionSegmenter {
 public:
  explicit MotionSegmenter(MotionSegmentationParams params);  // throws cofusion::Error on bad params

  const MotionSegmentationParams& params() const { return params_; }

  // Step 1 (needs only the frame): the superpixels, and with prepare_nodes for them the CRF's nodes
  // (position, colour, depth) and kernels, kept for segment(). rgb: w*h*3 bytes RGB; depth_m: w*h
  // metres, 0 or non-finite = no reading.
  Superpixels superpixels(const uint8_t* rgb, const float* depth_m, int width, int height, bool prepare_nodes = true);

  // Steps 2-4. `sp` from superpixels() on the same frame (rgb, depth_m as there, unchanged since);
  // superpixels made elsewhere (serial 0) or by an earlier call get their nodes here.
  // costs[m]: per-pixel ICP alignment cost of model m after tracking (metres, >= 0; NaN = model m
  // has no geometry at this pixel), w*h values each; costs.size() <= kMaxModels.
  SegmentationResult segment(const Superpixels& sp, const uint8_t* rgb, const float* depth_m,
                             std::span<const std::span<const float>> costs);

  // --- Building blocks, public for tests. ---
  // Per superpixel features and mean costs (unary step; the features and the CRF's kernels come
  // from superpixels() where it made `sp`). Node i of the CRF is superpixel crf_superpixel[i];
  // superpixels without valid depth are not nodes (crf_node_of = -1).
  struct Unaries {
    std::vector<CrfNode> nodes;
    std::vector<int32_t> crf_superpixel;  // node -> superpixel
    std::vector<int32_t> crf_node_of;     // superpixel -> node or -1
    std::vector<float> energy;            // node-major, nodes x (models + 1); last = outlier
    float depth_range_m = 0;
  };
  const Unaries& compute_unaries(const Superpixels& sp, const uint8_t* rgb, const float* depth_m,
                                 std::span<const std::span<const float>> costs);

  // Post-processing of pixel labels in place (labels 0..model_count, kNoLabel ignored); fills
  // result.outlier_components and result.model_pixels.
  void postprocess(std::vector<uint8_t>& labels, int width, int height, int model_count,
                   SegmentationResult& result);

 private:
  // What needs only the frame: per superpixel sums (base_sums_), the depth range, the CRF's nodes
  // and its kernels (crf_.set_nodes). Marks `sp` as prepared.
  void prepare_nodes(const Superpixels& sp, const uint8_t* rgb, const float* depth_m);
  // Per superpixel sums over the frame in fixed row chunks: the base sums, or the costs' sums
  // (also the depth range where asked). Throws for a bad superpixel label or cost.
  std::vector<double> chunk_sums(const Superpixels& sp, const uint8_t* rgb, const float* depth_m,
                                 std::span<const std::span<const float>> costs, bool base, float* depth_range_m);
  // unaries_'s energies from the per-superpixel cost sums (M models).
  void make_energies(const std::vector<double>& cost_sums, int M);

  MotionSegmentationParams params_;
  Slic slic_;
  DenseCrf crf_;
  Unaries unaries_;
  std::vector<double> partial_, base_sums_;  // base_sums_: kBaseSums per superpixel of prepared_serial_
  uint64_t last_serial_ = 0, prepared_serial_ = 0;
  std::vector<float> q_;
  std::vector<uint8_t> node_label_;
  ComponentLabelling components_;
  double last_slic_ms_ = 0, last_prepare_ms_ = 0;
};

}  // namespace cofusion::segmentation
