#pragma once
// Timing of the motion segmentation steps on a synthetic frame, for the benchmark executable and
// the tests' timing print. Not an accuracy test.
#include <cstdint>
#include <vector>

#include "segmentation/dense_crf.h"

namespace cofusion::segmentation {

// A deterministic textured RGB-D frame with rectangular objects in front of a sloped background,
// and per-pixel ICP costs: model 0 (background) ~2 mm everywhere except on the "moved" block
// (5 cm); model m >= 1 has geometry (~2 mm) only on its own rectangle, NaN elsewhere.
struct SyntheticSegmentationFrame {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;                // w*h*3
  std::vector<float> depth_m;              // w*h, a few holes (0)
  std::vector<std::vector<float>> costs;   // per model, w*h metres or NaN
  int moved_x0 = 0, moved_y0 = 0, moved_x1 = 0, moved_y1 = 0;  // the moved block, [x0,x1) x [y0,y1)
};
SyntheticSegmentationFrame make_synthetic_segmentation_frame(int width, int height, int model_count, uint32_t seed = 1);

struct SegmentationBenchConfig {
  int width = 640, height = 480;   // pixels
  int superpixel_size_px = 16;     // SLIC grid step (640x480: 32 -> 300, 16 -> 1200, 8 -> 4800)
  int model_count = 2;             // active models (labels = models + outlier)
  CrfMethod crf_method = CrfMethod::kPermutohedral;
  int repeats = 5;                 // timed runs after one warm-up; medians are reported
};

struct SegmentationBenchTimings {
  int superpixels = 0, crf_nodes = 0;
  // Medians, milliseconds; prepare: the CRF's nodes and kernels, made with the superpixels.
  double slic_ms = 0, prepare_ms = 0, unary_ms = 0, crf_ms = 0, post_ms = 0, total_ms = 0;
};

SegmentationBenchTimings bench_segmentation(const SegmentationBenchConfig& config);

}  // namespace cofusion::segmentation
