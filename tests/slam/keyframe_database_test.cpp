// Keyframe encodings for relocalisation: block means, normalisation, dissimilarity, novelty and the
// nearest keyframes.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "slam/keyframe_database.h"

namespace cofusion::test {
namespace {
using slam::FrameEncoding;
using slam::KeyframeDatabase;
using slam::KeyframeParams;

struct Image {
  int width, height;
  std::vector<uint8_t> rgb;
  std::vector<float> depth_m;
};

// A horizontal intensity ramp shifted by `shift_px`, over a plane at `depth_m`.
Image ramp(int width, int height, int shift_px, float depth_m) {
  Image im{width, height, std::vector<uint8_t>(size_t(width) * height * 3), std::vector<float>(size_t(width) * height, depth_m)};
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c)
        im.rgb[3 * (size_t(y) * width + x) + c] = static_cast<uint8_t>((((x + shift_px) * 255) / width + y) % 256);
  return im;
}

Eigen::Isometry3d translated(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = x;
  return T;
}

TEST(KeyframeDatabase, EncodingIsBlockMeansNormalisedAndMarksSparseDepth) {
  KeyframeParams p;
  p.cols = 4, p.rows = 2;
  const KeyframeDatabase db(p);
  // Left half dark (50), right half bright (150); depth valid only in the top row of blocks.
  Image im{8, 4, std::vector<uint8_t>(8 * 4 * 3), std::vector<float>(8 * 4, 0.0f)};
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) {
      for (int c = 0; c < 3; ++c) im.rgb[3 * (y * 8 + x) + c] = x < 4 ? 50 : 150;
      if (y < 2) im.depth_m[size_t(y * 8 + x)] = 1.0f + 0.5f * float(x / 2);
    }
  const FrameEncoding e = db.encode(im.rgb.data(), im.depth_m.data(), 8, 4);
  ASSERT_EQ(e.intensity.size(), 8u);
  for (int b = 0; b < 8; ++b) EXPECT_NEAR(e.intensity[size_t(b)], (b % 4) < 2 ? -1.0f : 1.0f, 1e-5) << b;
  for (int b = 0; b < 4; ++b) EXPECT_FLOAT_EQ(e.depth_m[size_t(b)], 1.0f + 0.5f * float(b)) << b;
  for (int b = 4; b < 8; ++b) EXPECT_EQ(e.depth_m[size_t(b)], 0.0f) << b;
}

TEST(KeyframeDatabase, UniformImageEncodesToZeroContrastWithoutNaN) {
  const KeyframeDatabase db{KeyframeParams{}};
  Image im{64, 48, std::vector<uint8_t>(64 * 48 * 3, 7), std::vector<float>(64 * 48, 0.0f)};
  const FrameEncoding e = db.encode(im.rgb.data(), im.depth_m.data(), 64, 48);
  for (float v : e.intensity) EXPECT_EQ(v, 0.0f);
  // No depth at all: nothing to compare with any keyframe.
  EXPECT_TRUE(std::isinf(db.dissimilarity(e, e)));
}

TEST(KeyframeDatabase, DissimilarityGrowsWithShiftAndDepthAndIgnoresExposure) {
  const KeyframeDatabase db{KeyframeParams{}};
  const Image a = ramp(160, 120, 0, 2.0f);
  const FrameEncoding ea = db.encode(a.rgb.data(), a.depth_m.data(), 160, 120);
  EXPECT_NEAR(db.dissimilarity(ea, ea), 0.0, 1e-9);
  // Half the brightness: normalised away.
  Image dim = a;
  for (auto& c : dim.rgb) c = static_cast<uint8_t>(c / 2);
  EXPECT_LT(db.dissimilarity(ea, db.encode(dim.rgb.data(), dim.depth_m.data(), 160, 120)), 0.05);
  const Image b = ramp(160, 120, 20, 2.0f), c = ramp(160, 120, 60, 2.0f), d = ramp(160, 120, 0, 2.3f);
  const double ab = db.dissimilarity(ea, db.encode(b.rgb.data(), b.depth_m.data(), 160, 120));
  const double ac = db.dissimilarity(ea, db.encode(c.rgb.data(), c.depth_m.data(), 160, 120));
  EXPECT_GT(ab, 0.05);
  EXPECT_GT(ac, ab);
  // 30 cm of depth at 10 per metre: 3 units.
  EXPECT_NEAR(db.dissimilarity(ea, db.encode(d.rgb.data(), d.depth_m.data(), 160, 120)), 3.0, 1e-4);
}

TEST(KeyframeDatabase, KeepsOnlyNovelPosesAndFindsTheMostSimilar) {
  KeyframeParams p;
  p.max_keyframes = 3;
  KeyframeDatabase db(p);
  int features_computed = 0;
  const auto no_features = [&] { return ++features_computed, slam::FrameFeatures{}; };
  const std::vector<int> shifts = {0, 40, 80, 120};
  std::vector<FrameEncoding> enc;
  for (int s : shifts) {
    const Image im = ramp(160, 120, s, 2.0f);
    enc.push_back(db.encode(im.rgb.data(), im.depth_m.data(), 160, 120));
  }
  EXPECT_TRUE(db.add_if_novel(enc[0], no_features, translated(0.0)));
  EXPECT_FALSE(db.add_if_novel(enc[1], no_features, translated(0.05)));  // within 10 cm of the first
  EXPECT_TRUE(db.add_if_novel(enc[1], no_features, translated(0.5)));
  EXPECT_TRUE(db.add_if_novel(enc[2], no_features, translated(1.0)));
  EXPECT_EQ(db.size(), 3u);
  EXPECT_EQ(features_computed, 3);  // not for the frame that was not added
  const auto nearest = db.nearest(enc[1], 2);
  ASSERT_EQ(nearest.size(), 2u);
  EXPECT_NEAR(nearest[0].translation().x(), 0.5, 1e-12);
  // The fourth drops the oldest.
  EXPECT_TRUE(db.add_if_novel(enc[3], no_features, translated(1.5)));
  EXPECT_EQ(db.size(), 3u);
  for (const auto& T : db.nearest(enc[0], 3)) EXPECT_GT(T.translation().x(), 0.25);
}

// A textured wall 2 m in front of the camera; the camera then moves 8 cm to its left (the wall's
// image shifts right by fx * 0.08 / 2 = 21 px). The features of the moved view matched against the
// keyframe's give that pose by PnP, whatever the keyframe's encoding similarity.
TEST(KeyframeDatabase, FeaturesLocateAMovedCameraByPnP) {
  const Intrinsics k{525.0, 525.0, 319.5, 239.5, 640, 480};
  cv::Mat texture(60, 80, CV_8UC1);
  cv::randu(texture, 0, 256);
  cv::Mat wall;
  cv::resize(texture, wall, cv::Size(720, 480), 0, 0, cv::INTER_CUBIC);
  const auto view = [&](int offset_px, std::vector<uint8_t>& rgb) {
    rgb.resize(size_t(k.width) * size_t(k.height) * 3);
    for (int y = 0; y < k.height; ++y)
      for (int x = 0; x < k.width; ++x)
        for (int c = 0; c < 3; ++c) rgb[3 * (size_t(y) * size_t(k.width) + size_t(x)) + size_t(c)] = wall.at<uint8_t>(y, x + 40 - offset_px);
  };
  const double shift_m = 0.08, depth_m = 2.0;
  const int shift_px = int(std::lround(k.fx * shift_m / depth_m));
  std::vector<uint8_t> key_rgb, live_rgb;
  view(0, key_rgb);
  view(shift_px, live_rgb);
  const std::vector<float> depth(size_t(k.width) * size_t(k.height), float(depth_m));
  KeyframeDatabase db{KeyframeParams{}};
  const slam::FrameFeatures key = db.features(key_rgb.data(), depth.data(), k);
  ASSERT_GT(key.pixels.size(), 100u);
  ASSERT_TRUE(db.add_if_novel(db.encode(key_rgb.data(), depth.data(), k.width, k.height), [&] { return key; }, Eigen::Isometry3d::Identity()));
  const auto poses = db.pnp_poses(db.encode(live_rgb.data(), depth.data(), k.width, k.height),
                                  db.features(live_rgb.data(), depth.data(), k), k);
  ASSERT_FALSE(poses.empty());
  // The scene moved right in the image: the camera moved left (-x), without turning.
  EXPECT_NEAR(poses[0].translation().x(), -double(shift_px) * depth_m / k.fx, 0.01);
  EXPECT_NEAR(poses[0].translation().y(), 0.0, 0.01);
  EXPECT_NEAR(poses[0].translation().z(), 0.0, 0.02);
  EXPECT_LT(Eigen::AngleAxisd(poses[0].rotation()).angle(), 0.01);
  // Features of an unrelated view find nothing.
  std::vector<uint8_t> other(live_rgb.size());
  cv::Mat noise(k.height, k.width * 3, CV_8UC1, other.data());
  cv::randu(noise, 0, 256);
  EXPECT_TRUE(db.pnp_poses(db.encode(other.data(), depth.data(), k.width, k.height), db.features(other.data(), depth.data(), k), k).empty());
}

// pnp_pose: the matches of every keyframe at once, their points taken to world coordinates by
// each keyframe's pose. Two keyframes of a textured wall, 2 m away, from a camera turned and moved
// in the world; the live camera halfway between them.
TEST(KeyframeDatabase, FeaturesOfSeveralKeyframesLocateTheCameraTogether) {
  const Intrinsics k{525.0, 525.0, 319.5, 239.5, 640, 480};
  cv::theRNG().state = 20261126;  // the same wall in every run, alone or after other tests
  cv::Mat texture(60, 80, CV_8UC1);
  cv::randu(texture, 0, 256);
  cv::Mat wall;
  cv::resize(texture, wall, cv::Size(720, 480), 0, 0, cv::INTER_CUBIC);
  const auto view = [&](int offset_px) {  // the wall seen from a camera offset_px * depth / fx to the left
    std::vector<uint8_t> rgb(size_t(k.width) * size_t(k.height) * 3);
    for (int y = 0; y < k.height; ++y)
      for (int x = 0; x < k.width; ++x)
        for (int c = 0; c < 3; ++c) rgb[3 * (size_t(y) * size_t(k.width) + size_t(x)) + size_t(c)] = wall.at<uint8_t>(y, x + 40 - offset_px);
    return rgb;
  };
  const double depth_m = 2.0;
  const int step_px = 16;
  const double step_m = step_px * depth_m / k.fx;
  const std::vector<float> depth(size_t(k.width) * size_t(k.height), float(depth_m));
  Eigen::Isometry3d T_world_a = Eigen::Isometry3d::Identity();
  T_world_a.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
  T_world_a.pretranslate(Eigen::Vector3d(0.5, -0.2, 1.0));
  const auto left = [](double x) { return translated(-x); };
  // Keyframe b's pose is 1 cm off (its tracking's error): the joint pose lies between the two.
  const double b_error_m = 0.01;
  KeyframeDatabase db{KeyframeParams{}};
  const std::vector<uint8_t> a_rgb = view(0), b_rgb = view(2 * step_px), live_rgb = view(step_px);
  ASSERT_TRUE(db.add_if_novel(db.encode(a_rgb.data(), depth.data(), k.width, k.height),
                              [&] { return db.features(a_rgb.data(), depth.data(), k); }, T_world_a));
  ASSERT_TRUE(db.add_if_novel(db.encode(b_rgb.data(), depth.data(), k.width, k.height),
                              [&] { return db.features(b_rgb.data(), depth.data(), k); },
                              T_world_a * left(2 * step_m - b_error_m)));
  const slam::FrameEncoding live_encoding = db.encode(live_rgb.data(), depth.data(), k.width, k.height);
  const slam::FrameFeatures live = db.features(live_rgb.data(), depth.data(), k);
  const auto pose = db.pnp_pose(live_encoding, live, k);
  ASSERT_TRUE(pose.has_value());
  const Eigen::Isometry3d T_a_live = T_world_a.inverse() * pose->T_world_camera;
  const double error_x = T_a_live.translation().x() - (-step_m);  // b pulls it to the right
  EXPECT_GT(error_x, 0.1 * b_error_m);
  EXPECT_LT(error_x, 0.9 * b_error_m);
  // A flat wall trades a little rotation about x for translation along y (4 mrad: 8 mm at 2 m).
  EXPECT_NEAR(T_a_live.translation().y(), 0.0, 0.01);
  EXPECT_NEAR(T_a_live.translation().z(), 0.0, 0.01);
  EXPECT_LT(Eigen::AngleAxisd(T_a_live.rotation()).angle(), 0.01);
  // Each keyframe alone gives its own answer (the relocaliser's pnp_poses).
  EXPECT_EQ(db.pnp_poses(live_encoding, live, k).size(), 2u);
  // Both keyframes' matches support it: more inliers than either keyframe's features alone hold.
  EXPECT_GT(pose->inliers, int(live.pixels.size()));
  // Features of an unrelated view find nothing.
  std::vector<uint8_t> other(live_rgb.size());
  cv::Mat noise(k.height, k.width * 3, CV_8UC1, other.data());
  cv::randu(noise, 0, 256);
  EXPECT_FALSE(db.pnp_pose(db.encode(other.data(), depth.data(), k.width, k.height), db.features(other.data(), depth.data(), k), k));
}

TEST(KeyframeDatabase, RejectsBadParameters) {
  KeyframeParams p;
  p.cols = 0;
  EXPECT_THROW(KeyframeDatabase{p}, Error);
  p = {};
  p.max_keyframes = 0;
  EXPECT_THROW(KeyframeDatabase{p}, Error);
  p = {};
  p.min_valid_fraction = 0;
  EXPECT_THROW(KeyframeDatabase{p}, Error);
}

}  // namespace
}  // namespace cofusion::test
