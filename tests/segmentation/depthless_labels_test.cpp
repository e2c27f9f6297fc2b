// Labels for pixels without depth, from their superpixel's pixels with depth.
#include "segmentation/depthless_labels.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/error.h"

namespace cofusion::segmentation {
namespace {

constexpr uint16_t kNone = 0xFFFF;
constexpr float kNoDepth = 0.0f;

// One row of `labels.size()` pixels split into superpixels as `superpixel` says.
Superpixels row_of(const std::vector<int32_t>& superpixel) {
  Superpixels s;
  s.width = static_cast<int>(superpixel.size());
  s.height = 1;
  s.label = superpixel;
  s.count = 0;
  for (int32_t l : superpixel) s.count = std::max(s.count, l + 1);
  return s;
}

TEST(DepthlessLabels, TakeTheMajorityOfTheirSuperpixelsPixelsWithDepth) {
  // Superpixel 0: model 3 on two of three pixels with depth -> its depthless pixel becomes 3.
  // Superpixel 1: model 5 on one of two (a tie, not more than half) -> stays none.
  // Superpixel 2: mostly unassigned -> stays none. Superpixel 3: no pixel with depth -> none.
  const Superpixels s = row_of({0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2, 3});
  std::vector<uint16_t> labels = {3, 3, kNone, kNone, 5, 6, kNone, kNone, kNone, 7, kNone, kNone};
  const std::vector<float> depth = {1, 1, 1, kNoDepth, 1, 1, kNoDepth, 1, 1, 1, NAN, kNoDepth};
  label_depthless_pixels(labels, s, depth.data(), kNone);
  EXPECT_EQ(labels, (std::vector<uint16_t>{3, 3, kNone, 3, 5, 6, kNone, kNone, kNone, 7, kNone, kNone}));
}

TEST(DepthlessLabels, LeavePixelsWithDepthAndLabelledPixelsAlone) {
  const Superpixels s = row_of({0, 0, 0, 0});
  std::vector<uint16_t> labels = {2, 2, 9, kNone};  // the depthless 9 keeps its label
  const std::vector<float> depth = {1, 1, kNoDepth, 1};
  label_depthless_pixels(labels, s, depth.data(), kNone);
  EXPECT_EQ(labels, (std::vector<uint16_t>{2, 2, 9, kNone}));
}

TEST(DepthlessLabels, LeaveExcludedPixelsAlone) {
  const Superpixels s = row_of({0, 0, 0, 0});
  std::vector<uint16_t> labels = {2, 2, kNone, kNone};
  const std::vector<float> depth = {1, 1, kNoDepth, kNoDepth};
  const std::vector<uint8_t> excluded = {0, 0, 1, 0};  // a person's pixel without depth
  label_depthless_pixels(labels, s, depth.data(), kNone, excluded);
  EXPECT_EQ(labels, (std::vector<uint16_t>{2, 2, kNone, 2}));
}

TEST(DepthlessLabels, RejectMismatchedSizes) {
  const Superpixels s = row_of({0, 0, 1});
  std::vector<uint16_t> labels(2, kNone);
  const std::vector<float> depth(3, 1.0f);
  EXPECT_THAT([&] { label_depthless_pixels(labels, s, depth.data(), kNone); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("2 labels")));
}

}  // namespace
}  // namespace cofusion::segmentation
