// The detector's schedule (AsyncDetector): which frames get which detection, how old it is and
// whether it was handed out before. Needs the models of .ci/fetch-models.sh in $COFUSION_MODELS;
// skips with a message without them.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <vector>

#include <opencv2/core.hpp>

#include "commands/semantic_source.h"

namespace cofusion::test {
namespace {
namespace fs = std::filesystem;
using commands::AsyncDetector;

struct Handed {
  bool given = false;
  int age_frames = -1;
  bool repeated = false;
};

// Runs the detector over `frames` frames (a grey wall 2 m away), each frame asking for its masks
// and then submitting itself, as FrameMasks does.
std::vector<Handed> schedule(const fs::path& models, int frames, int every, int max_age) {
  const Intrinsics k;  // 640x480
  AsyncDetector detector(models, k, /*wait_for_result=*/true, every, max_age);
  const cv::Mat rgb(k.height, k.width, CV_8UC3, cv::Scalar(128, 128, 128));
  const cv::Mat depth_m(k.height, k.width, CV_32FC1, cv::Scalar(2.0f));
  std::vector<Handed> out;
  for (int i = 0; i < frames; ++i) {
    const slam::SemanticFrame* s = detector.for_frame();
    out.push_back(s ? Handed{true, s->age_frames, s->repeated} : Handed{});
    if (s) {
      EXPECT_EQ(s->ids.size(), size_t(k.width) * size_t(k.height)) << "frame " << i;
    }
    detector.submit(i, rgb, depth_m);
  }
  return out;
}

#define REQUIRE_MODELS(var)                                                                   \
  const char* var##_env = std::getenv("COFUSION_MODELS");                                      \
  if (!var##_env || !fs::is_regular_file(fs::path(var##_env) / "centernet.pb"))                \
    GTEST_SKIP() << "centernet.pb not in $COFUSION_MODELS: run .ci/fetch-models.sh";          \
  const fs::path var(var##_env)

// Every frame detected: each frame gets the previous frame's detection, one frame old, new each time.
TEST(AsyncDetector, EachFrameGetsThePreviousFramesDetection) {
  REQUIRE_MODELS(models);
  const std::vector<Handed> h = schedule(models, 4, 1, 1);
  EXPECT_FALSE(h[0].given);  // nothing was detected before the first frame
  for (int i = 1; i < 4; ++i) {
    EXPECT_TRUE(h[size_t(i)].given) << i;
    EXPECT_EQ(h[size_t(i)].age_frames, 1) << i;
    EXPECT_FALSE(h[size_t(i)].repeated) << i;
  }
}

// Every third frame detected: a detection is carried to the three frames after its own, older each
// frame and repeated from its second; with a shorter max age the last of them get none.
TEST(AsyncDetector, ADetectionIsCarriedUntilTheNextOne) {
  REQUIRE_MODELS(models);
  const std::vector<Handed> h = schedule(models, 8, 3, 3);
  const std::vector<int> ages = {-1, 1, 2, 3, 1, 2, 3, 1};  // detections on frames 0, 3 and 6
  for (size_t i = 0; i < h.size(); ++i) {
    EXPECT_EQ(h[i].given, ages[i] > 0) << i;
    if (!h[i].given) continue;
    EXPECT_EQ(h[i].age_frames, ages[i]) << i;
    EXPECT_EQ(h[i].repeated, ages[i] > 1) << i;
  }
  const std::vector<Handed> short_lived = schedule(models, 4, 3, 2);
  EXPECT_TRUE(short_lived[2].given);
  EXPECT_EQ(short_lived[2].age_frames, 2);
  EXPECT_FALSE(short_lived[3].given);  // 3 frames old: past max_age_frames
}

}  // namespace
}  // namespace cofusion::test
