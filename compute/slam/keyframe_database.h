#pragma once
// Keyframes for relocalisation after a tracking loss. Each keyframe is a camera pose with two
// descriptions of what the camera saw there:
//  - a small, blurred encoding: the frame's intensity and depth averaged over blocks of pixels (a
//    "small blurry image", Klein & Murray 2008, the encoding ElasticFusion's randomized ferns
//    sample from). A lost frame is encoded the same way; the keyframes whose encodings differ
//    least from it are poses to try tracking from (the camera is near one of them again);
//  - ORB features with their 3-D points (from depth): matched against a lost frame's features,
//    a RANSAC PnP pose gives where the camera is even when no keyframe is close (a covered lens
//    while the camera moved on 30 cm), which ICP alone cannot reach.
// Host only: the encoding costs about 1 ms at 640x480, features 5-10 ms (only for new keyframes
// and lost frames).
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "common/intrinsics.h"

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
  // Features: ORB keypoints per frame; a match needs a second-best descriptor distance at least
  // 1 / match_ratio times the best (Lowe's ratio test); PnP RANSAC accepts a pose with at least
  // min_pnp_inliers matches within max_reprojection_px.
  int orb_features = 1000;
  double match_ratio = 0.8;
  int min_pnp_inliers = 8;
  double max_reprojection_px = 3.0;
  // Keyframes whose features are matched: the most similar by encoding plus the newest.
  int pnp_similar_keyframes = 5;
  int pnp_newest_keyframes = 3;
};

// ORB keypoints of a frame that have depth, with their points in the camera frame (metres).
struct FrameFeatures {
  std::vector<cv::Point2f> pixels;
  std::vector<cv::Point3f> points_camera;
  cv::Mat descriptors;  // one row per keypoint
};

struct FrameEncoding {
  std::vector<float> intensity;  // cols * rows, normalised (zero mean, unit std over the blocks)
  std::vector<float> depth_m;    // cols * rows, mean of the valid readings; 0 = too few valid
};

// A camera pose from features matched against keyframes (KeyframeDatabase::pnp_pose).
struct KeyframePose {
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  int inliers = 0;  // RANSAC's inlier matches (a feature matched in several keyframes counts in each)
};

class KeyframeDatabase {
 public:
  explicit KeyframeDatabase(const KeyframeParams& params);  // throws cofusion::Error on bad params

  // rgb: width*height*3 bytes; depth_m: width*height metres (0 or non-finite = no reading).
  FrameEncoding encode(const uint8_t* rgb, const float* depth_m, int width, int height) const;
  // Mean normalised difference of two encodings (see KeyframeParams); +infinity when too few
  // blocks are comparable.
  double dissimilarity(const FrameEncoding& a, const FrameEncoding& b) const;

  // ORB features of the frame with depth (rgb, depth_m as for encode()).
  FrameFeatures features(const uint8_t* rgb, const float* depth_m, const Intrinsics& intrinsics) const;
  // Adds the frame as a keyframe when its pose is far enough from every stored keyframe's; its
  // features are computed (by `features`) only then. Returns whether it was added.
  bool add_if_novel(const FrameEncoding& encoding, const std::function<FrameFeatures()>& features,
                    const Eigen::Isometry3d& T_world_camera);
  // Camera poses (T_world_camera) for a lost frame from its features matched against keyframes'
  // (KeyframeParams::pnp_*), one per keyframe, best supported first.
  std::vector<Eigen::Isometry3d> pnp_poses(const FrameEncoding& encoding, const FrameFeatures& features,
                                           const Intrinsics& intrinsics) const;
  // One camera pose (T_world_camera) from the frame's features matched against those of the same
  // keyframes together (their points in world coordinates), RANSAC PnP refined on its inliers;
  // nullopt without enough matches. Steadier than any one keyframe's pose where the keyframes'
  // poses are each a little off (CameraCheckParams::keyframe_pull_gain).
  std::optional<KeyframePose> pnp_pose(const FrameEncoding& encoding, const FrameFeatures& features,
                                       const Intrinsics& intrinsics) const;
  // Poses of the at most `count` keyframes most similar to `encoding`, most similar first
  // (keyframes that are not comparable at all are left out).
  std::vector<Eigen::Isometry3d> nearest(const FrameEncoding& encoding, int count) const;
  size_t size() const { return keyframes_.size(); }

 private:
  std::vector<size_t> pnp_keyframes(const FrameEncoding& encoding) const;
  struct Keyframe {
    FrameEncoding encoding;
    FrameFeatures features;
    Eigen::Isometry3d T_world_camera;
  };
  KeyframeParams params_;
  std::vector<Keyframe> keyframes_;
};

}  // namespace cofusion::slam
