#pragma once
// SLIC superpixels (Achanta et al. 2012) on the CPU, in RGB like Co-Fusion's gSLICr setup, with an
// optional depth term. Pixel-centric assignment as in gSLICr: every pixel compares itself with the
// 3x3 cluster centres around its grid cell, so rows are independent and run in parallel. The
// iterations run at half resolution, then every pixel is assigned once at full resolution, and
// disconnected pieces are merged or split off so that every superpixel is 4-connected.
// 640x480, S = 16, 5 iterations: about 9 ms on one thread, 5 ms on two (2-core dev machine).
#include <cstdint>
#include <memory>
#include <vector>

namespace cofusion::segmentation {

struct SlicParams {
  // Grid step, pixels: the image is seeded with round(w/S) x round(h/S) clusters
  // (640x480 -> 40x30 = 1200 superpixels, Co-Fusion's setting).
  int superpixel_size_px = 16;
  // SLIC's m: the RGB distance (0..255 levels, Euclidean) that weighs as much as a spatial
  // distance of one grid step. Larger -> more compact, less boundary-adherent superpixels.
  float compactness = 40.0f;
  // Assignment/update rounds (at half resolution when coarse_to_fine applies).
  int iterations = 5;
  // Run the iterations on a 2x2-averaged half-resolution image (4x cheaper), then assign every
  // full-resolution pixel once to the resulting centres, so boundaries stay pixel-accurate.
  // Applies when the grid step is >= 8 px; smaller steps run at full resolution.
  bool coarse_to_fine = true;
  // Depth term: RGB levels per metre of depth difference, added to the colour distance where both
  // the pixel and the cluster centre have depth (100: a 10 cm step counts like 10 RGB levels, so
  // superpixels also follow depth edges between similarly coloured surfaces). 0 switches it off.
  float depth_weight_per_m = 100.0f;
  // Connectivity: pieces of a cluster smaller than this fraction of the nominal superpixel area
  // (S*S) are merged into the adjacent superpixel of closest mean colour; larger disconnected pieces
  // become superpixels of their own.
  float min_piece_fraction = 0.25f;
};

struct Superpixels {
  int width = 0, height = 0;  // image size, pixels
  int count = 0;              // superpixels; labels are 0..count-1
  // Per pixel (row-major), 0..count-1; every pixel is assigned and every superpixel is
  // 4-connected. Numbered in raster order of each superpixel's first pixel.
  std::vector<int32_t> label;
  // The grid step actually used, pixels (x and y; close to superpixel_size_px), so that
  // positions can be expressed in grid units (the CRF's position scale).
  float step_x_px = 0, step_y_px = 0;
  // Which MotionSegmenter::superpixels() call made these (0: made elsewhere). segment() reuses the
  // CRF nodes that call prepared from the same frame.
  uint64_t serial = 0;
};

// Scratch buffers kept between frames; one thread at a time (uses TBB inside).
class Slic {
 public:
  Slic();
  ~Slic();
  Slic(Slic&&) noexcept;
  Slic& operator=(Slic&&) noexcept;

  // rgb: width*height*3 bytes (R, G, B per pixel, row-major). depth_m: width*height metres, 0 or
  // non-finite = no reading; may be null when params.depth_weight_per_m == 0.
  // Throws cofusion::Error for null pointers, non-positive sizes or bad parameters.
  Superpixels compute(const uint8_t* rgb, const float* depth_m, int width, int height,
                      const SlicParams& params);

  // Milliseconds of the last compute(): clustering (planes, iterations, final assignment) and
  // connectivity enforcement.
  double last_clustering_ms() const { return clustering_ms_; }
  double last_connectivity_ms() const { return connectivity_ms_; }

 private:
  struct Scratch;
  std::unique_ptr<Scratch> scratch_;
  double clustering_ms_ = 0, connectivity_ms_ = 0;
};

// Convenience wrapper around a temporary Slic.
Superpixels compute_slic(const uint8_t* rgb, const float* depth_m, int width, int height,
                         const SlicParams& params);

}  // namespace cofusion::segmentation
