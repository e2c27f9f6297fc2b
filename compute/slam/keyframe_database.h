#pragma once
// Keyframes for relocalisation after a tracking loss. Each keyframe is a camera pose with a small,
// blurred encoding of what the camera saw there: the frame's intensity and depth averaged over
// blocks of pixels (a "small blurry image", Klein & Murray 2008, the encoding ElasticFusion's
// randomized ferns sample from). A lost frame is encoded the same way; the keyframes whose
// encodings differ least from it are the poses to try tracking from. Host only: encoding a frame
// costs about 1 ms at 640x480, the database holds a few hundred keyframes of 2 x 1200 floats.
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

namespace cofusion::slam {

struct KeyframeParams {
  // Encoding resolution, blocks across and down (the frame is averaged over width/cols x
  // height/rows pixel blocks).
  int cols = 40;
  int rows = 30;
  // A block's depth (metres) is compared only where both encodings have at least this fraction of
  // valid depth readings in it.
  double min_valid_fraction = 0.5;
  // Dissimilarity = mean |intensity difference| (intensity normalised to zero mean and unit
  // standard deviation per encoding, so exposure changes cancel) + depth_weight_per_m * mean
  // |depth difference| over blocks valid in both, metres. 10 / m makes 10 cm of depth weigh as one
  // standard deviation of intensity.
  double depth_weight_per_m = 10.0;
  // Blocks valid in both encodings below this fraction: no comparison (dissimilarity infinite).
  double min_overlap_fraction = 0.2;
  // A tracked frame becomes a keyframe when its pose is at least this far from every keyframe's
  // (translation, metres or rotation, degrees) ...
  double min_translation_m = 0.1;
  double min_rotation_deg = 10.0;
  // ... and at most this many are kept (the oldest are dropped first).
  int max_keyframes = 500;
};

struct FrameEncoding {
  std::vector<float> intensity;  // cols * rows, normalised (zero mean, unit std over the blocks)
  std::vector<float> depth_m;    // cols * rows, mean of the valid readings; 0 = too few valid
};

class KeyframeDatabase {
 public:
  explicit KeyframeDatabase(const KeyframeParams& params);  // throws cofusion::Error on bad params

  // rgb: width*height*3 bytes; depth_m: width*height metres (0 or non-finite = no reading).
  FrameEncoding encode(const uint8_t* rgb, const float* depth_m, int width, int height) const;
  // Mean normalised difference of two encodings (see KeyframeParams); +infinity when too few
  // blocks are comparable.
  double dissimilarity(const FrameEncoding& a, const FrameEncoding& b) const;

  // Adds the frame as a keyframe when its pose is far enough from every stored one. Returns
  // whether it was added.
  bool add_if_novel(const FrameEncoding& encoding, const Eigen::Isometry3d& T_world_camera);
  // Poses of the at most `count` keyframes most similar to `encoding`, most similar first
  // (keyframes that are not comparable at all are left out).
  std::vector<Eigen::Isometry3d> nearest(const FrameEncoding& encoding, int count) const;
  size_t size() const { return keyframes_.size(); }

 private:
  struct Keyframe {
    FrameEncoding encoding;
    Eigen::Isometry3d T_world_camera;
  };
  KeyframeParams params_;
  std::vector<Keyframe> keyframes_;
};

}  // namespace cofusion::slam
