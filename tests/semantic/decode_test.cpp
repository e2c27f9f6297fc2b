// CenterNet decoding on hand-made heatmaps: peaks, a plateau, the threshold, the border, box
// scaling to the image, one class per cell, ordering and the detection cap, bad input.
#include <gtest/gtest.h>

#include <vector>

#include "semantic/coco_classes.h"
#include "semantic/detector.h"
#include "support/test_support.h"

namespace cofusion::semantic {
namespace {

// A CenterNet output of `classes` x rows x cols, all zero, with helpers to set cells.
struct Output {
  int classes, rows, cols;
  std::vector<float> heatmap, wh;
  Output(int c, int r, int w)
      : classes(c), rows(r), cols(w), heatmap(static_cast<size_t>(c) * r * w, 0.f), wh(static_cast<size_t>(4) * r * w, 0.f) {}
  float& at(int c, int row, int col) { return heatmap[(static_cast<size_t>(c) * rows + row) * cols + col]; }
  void set_box(int row, int col, float left, float top, float right, float bottom) {
    const size_t plane = static_cast<size_t>(rows) * cols, i = static_cast<size_t>(row) * cols + col;
    wh[i] = left;
    wh[plane + i] = top;
    wh[2 * plane + i] = right;
    wh[3 * plane + i] = bottom;
  }
  std::vector<Detection> decode(int input_size, cv::Size image, const DetectorParams& p = {}) const {
    return decode_centernet(heatmap, wh, classes, rows, cols, input_size, image, p);
  }
};

void expect_box(const cv::Rect2f& got, const cv::Rect2f& want) {
  EXPECT_NEAR(got.x, want.x, 1e-4f);
  EXPECT_NEAR(got.y, want.y, 1e-4f);
  EXPECT_NEAR(got.width, want.width, 1e-4f);
  EXPECT_NEAR(got.height, want.height, 1e-4f);
}

TEST(DecodeCenterNet, PeaksBecomeScaledBoxes) {
  // 8x8 map of a 32-pixel input (stride 4), image 64x32: x scales by 2, y by 1.
  Output o(2, 8, 8);
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) o.at(1, 3 + dy, 2 + dx) = 0.5f;
  o.at(1, 3, 2) = 0.9f;
  o.set_box(3, 2, 4, 8, 12, 16);  // cell centre (8, 12) in input pixels
  o.at(0, 5, 5) = 0.6f;
  o.set_box(5, 5, 2, 2, 2, 2);
  const auto dets = o.decode(32, {64, 32});
  ASSERT_EQ(dets.size(), 2u);
  EXPECT_EQ(dets[0].class_id, 1);
  EXPECT_EQ(dets[0].class_name, "bicycle");
  EXPECT_FLOAT_EQ(dets[0].score, 0.9f);
  expect_box(dets[0].box_px, {8.f, 4.f, 32.f, 24.f});  // x (8-4..8+12)*2, y 12-8..12+16
  EXPECT_EQ(dets[1].class_name, "person");
  expect_box(dets[1].box_px, {36.f, 18.f, 8.f, 4.f});  // x (20-2..20+2)*2, y 20-2..20+2
}

TEST(DecodeCenterNet, APlateauGivesOneDetectionAtItsFirstCell) {
  Output o(1, 6, 6);
  o.at(0, 2, 2) = o.at(0, 2, 3) = o.at(0, 3, 2) = o.at(0, 3, 3) = 0.7f;
  o.at(0, 4, 4) = 0.5f;  // touches the plateau diagonally, lower: no peak
  const auto dets = o.decode(24, {24, 24});
  ASSERT_EQ(dets.size(), 1u);
  EXPECT_FLOAT_EQ(dets[0].box_px.x, 8.f);  // cell (row 2, col 2), zero-size box at 4 * 2
  EXPECT_FLOAT_EQ(dets[0].box_px.y, 8.f);
}

TEST(DecodeCenterNet, ValuesAtOrBelowTheThresholdAreNoDetections) {
  Output o(1, 5, 5);
  o.at(0, 1, 1) = 0.29f;
  o.at(0, 3, 3) = 0.3f;
  DetectorParams p;
  p.score_threshold = 0.3f;
  EXPECT_TRUE(o.decode(20, {20, 20}, p).empty());
  p.score_threshold = 0.2f;
  EXPECT_EQ(o.decode(20, {20, 20}, p).size(), 2u);
}

TEST(DecodeCenterNet, BorderPeaksCountAndBoxesAreClippedToTheImage) {
  Output o(1, 4, 4);
  o.at(0, 0, 0) = 0.8f;
  o.set_box(0, 0, 10, 10, 6, 6);  // reaches outside the top-left corner
  o.at(0, 3, 3) = 0.7f;
  o.set_box(3, 3, 1, 1, 100, 100);  // and past the bottom-right one
  const auto dets = o.decode(16, {16, 16});
  ASSERT_EQ(dets.size(), 2u);
  expect_box(dets[0].box_px, {0.f, 0.f, 6.f, 6.f});
  expect_box(dets[1].box_px, {11.f, 11.f, 5.f, 5.f});
}

TEST(DecodeCenterNet, OneClassPerCellUnlessAskedOtherwise) {
  Output o(3, 4, 4);
  o.at(0, 1, 1) = 0.5f;
  o.at(2, 1, 1) = 0.6f;  // the same centre, another class, better
  o.at(1, 2, 3) = 0.4f;
  const auto one = o.decode(16, {16, 16});
  ASSERT_EQ(one.size(), 2u);
  EXPECT_EQ(one[0].class_id, 2);
  EXPECT_EQ(one[1].class_id, 1);
  DetectorParams p;
  p.one_class_per_cell = false;
  EXPECT_EQ(o.decode(16, {16, 16}, p).size(), 3u);
}

TEST(DecodeCenterNet, BestFirstAndCapped) {
  Output o(1, 9, 9);
  const float scores[] = {0.4f, 0.9f, 0.6f, 0.6f, 0.8f};
  for (int i = 0; i < 5; ++i) o.at(0, 1 + 2 * (i % 4), 1 + 2 * (i / 4) * 3) = scores[i];
  DetectorParams p;
  p.max_detections = 3;
  const auto dets = o.decode(36, {36, 36}, p);
  ASSERT_EQ(dets.size(), 3u);
  EXPECT_FLOAT_EQ(dets[0].score, 0.9f);
  EXPECT_FLOAT_EQ(dets[1].score, 0.8f);
  EXPECT_FLOAT_EQ(dets[2].score, 0.6f);
  EXPECT_FLOAT_EQ(dets[2].box_px.y, 20.f) << "equal scores: the earlier row (5, not 7) first";
}

TEST(DecodeCenterNet, RejectsMismatchedSizes) {
  Output o(2, 4, 4);
  EXPECT_NE(test::error_of([&] { (void)decode_centernet(o.heatmap, o.wh, 3, 4, 4, 16, {16, 16}, {}); }), "(no error)");
  EXPECT_NE(test::error_of([&] { (void)decode_centernet(o.heatmap, o.wh, 2, 0, 4, 16, {16, 16}, {}); }), "(no error)");
}

TEST(CocoClasses, DarknetOrder) {
  EXPECT_EQ(kCocoClassNames.size(), 80u);
  EXPECT_EQ(coco_class_name(0), "person");
  EXPECT_EQ(coco_class_name(41), "cup");
  EXPECT_EQ(coco_class_name(62), "tvmonitor");
  EXPECT_EQ(coco_class_name(64), "mouse");
  EXPECT_EQ(coco_class_name(66), "keyboard");
  EXPECT_EQ(coco_class_name(79), "toothbrush");
  EXPECT_EQ(coco_class_name(80), "class_80");
  for (const auto name : kCocoClassNames) EXPECT_EQ(name.find(' '), std::string_view::npos) << name;
}

}  // namespace
}  // namespace cofusion::semantic
