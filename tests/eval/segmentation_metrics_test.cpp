#include "eval/segmentation_metrics.h"

#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "support/test_support.h"

namespace cofusion::eval {
namespace {

cv::Mat labels(int rows, int cols, std::initializer_list<int> values) {
  cv::Mat m(rows, cols, CV_16UC1);
  auto it = values.begin();
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) m.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(*it++);
  return m;
}

const LabelIou& find_gt(const FrameSegmentation& f, int gt_label) {
  for (const auto& l : f.gt_labels)
    if (l.gt_label == gt_label) return l;
  throw std::runtime_error("label not in frame");
}

TEST(Segmentation, IdenticalImagesUnderLabelPermutationScoreOne) {
  const cv::Mat gt = labels(2, 4, {0, 0, 1, 1,  //
                                   0, 2, 2, 1});
  const cv::Mat est = labels(2, 4, {5, 5, 0, 0,  //
                                    5, 7, 7, 0});
  const FrameSegmentation f = evaluate_segmentation_frame(gt, est);
  ASSERT_EQ(f.gt_labels.size(), 3u);
  EXPECT_EQ(find_gt(f, 0).est_label, 5);
  EXPECT_EQ(find_gt(f, 1).est_label, 0);
  EXPECT_EQ(find_gt(f, 2).est_label, 7);
  for (const auto& l : f.gt_labels) EXPECT_DOUBLE_EQ(l.iou, 1.0);
  EXPECT_TRUE(f.unmatched_est_labels.empty());
}

TEST(Segmentation, HandComputedIousAndUnmatchedLabels) {
  // gt: background 0 (6 px), object 1 (6 px). est: 0 covers 5 of background + 2 of object;
  // 3 covers 4 of object; 9 covers 1 background pixel.
  const cv::Mat gt = labels(3, 4, {0, 0, 0, 1,  //
                                   0, 0, 0, 1,  //
                                   1, 1, 1, 1});
  const cv::Mat est = labels(3, 4, {0, 0, 9, 0,  //
                                    0, 0, 0, 0,  //
                                    3, 3, 3, 3});
  const FrameSegmentation f = evaluate_segmentation_frame(gt, est);
  // IoU(0,0) = 5 / (6 + 7 - 5) = 5/8; IoU(1,3) = 4 / (6 + 4 - 4) = 4/6; 9 stays unmatched.
  EXPECT_EQ(find_gt(f, 0).est_label, 0);
  EXPECT_DOUBLE_EQ(find_gt(f, 0).iou, 5.0 / 8.0);
  EXPECT_EQ(find_gt(f, 1).est_label, 3);
  EXPECT_DOUBLE_EQ(find_gt(f, 1).iou, 4.0 / 6.0);
  EXPECT_EQ(find_gt(f, 1).intersection, 4u);
  EXPECT_EQ(f.unmatched_est_labels, (std::vector<int>{9}));
}

TEST(Segmentation, OptimalNotGreedyMatching) {
  // gt A = 1 (pixels 0-9), B = 2 (10-19). est X = 4 covers 8 of A and 6 of B, Y = 5 covers 2 of A.
  // IoU(A,X) = 8/16 is the largest entry, but (A,Y) + (B,X) = 2/10 + 6/18 beats (A,X) + (B,Y) = 0.5.
  const cv::Mat gt = labels(1, 20, {1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2});
  const cv::Mat est = labels(1, 20, {4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 4, 4, 4, 4, 4, 4, 0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF});
  const FrameSegmentation f = evaluate_segmentation_frame(gt, est);
  EXPECT_EQ(find_gt(f, 1).est_label, 5);
  EXPECT_DOUBLE_EQ(find_gt(f, 1).iou, 0.2);
  EXPECT_EQ(find_gt(f, 2).est_label, 4);
  EXPECT_DOUBLE_EQ(find_gt(f, 2).iou, 6.0 / 18.0);
}

TEST(Segmentation, IgnoredPixelsAndUnlabelledEstimate) {
  const cv::Mat gt = labels(1, 6, {1, 1, 1, 1, 0xFFFF, 0xFFFF});
  const cv::Mat est = labels(1, 6, {2, 2, 0xFFFF, 0xFFFF, 2, 7});
  const FrameSegmentation f = evaluate_segmentation_frame(gt, est);
  ASSERT_EQ(f.gt_labels.size(), 1u);
  // Ignored pixels vanish from both images (label 7 lies only there); unlabelled ones count for gt.
  EXPECT_DOUBLE_EQ(f.gt_labels[0].iou, 0.5);
  EXPECT_EQ(f.gt_labels[0].gt_pixels, 4u);
  EXPECT_EQ(f.gt_labels[0].est_pixels, 2u);
  EXPECT_TRUE(f.unmatched_est_labels.empty());
}

TEST(Segmentation, EmptyLabelsAndNoOverlap) {
  // Estimated image all unlabelled: every gt label unmatched with IoU 0.
  const cv::Mat gt = labels(1, 4, {0, 0, 3, 3});
  const FrameSegmentation none = evaluate_segmentation_frame(gt, labels(1, 4, {0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF}));
  ASSERT_EQ(none.gt_labels.size(), 2u);
  for (const auto& l : none.gt_labels) {
    EXPECT_EQ(l.est_label, -1);
    EXPECT_EQ(l.iou, 0.0);
  }
  // Ground truth entirely ignored: nothing to evaluate, every estimated label is left out too.
  const FrameSegmentation ignored = evaluate_segmentation_frame(labels(1, 2, {0xFFFF, 0xFFFF}), labels(1, 2, {1, 2}));
  EXPECT_TRUE(ignored.gt_labels.empty());
  EXPECT_TRUE(ignored.unmatched_est_labels.empty());
}

TEST(Segmentation, EightBitEstimateAndBadInputs) {
  const cv::Mat gt = labels(1, 3, {0, 1, 1});
  cv::Mat est8(1, 3, CV_8UC1);
  est8.at<std::uint8_t>(0, 0) = 0;
  est8.at<std::uint8_t>(0, 1) = 200;
  est8.at<std::uint8_t>(0, 2) = 200;
  const FrameSegmentation f = evaluate_segmentation_frame(gt, est8);
  EXPECT_EQ(find_gt(f, 1).est_label, 200);
  EXPECT_DOUBLE_EQ(find_gt(f, 1).iou, 1.0);
  EXPECT_THROW(evaluate_segmentation_frame(gt, labels(1, 2, {0, 1})), Error);
  EXPECT_THROW(evaluate_segmentation_frame(gt, cv::Mat(1, 3, CV_8UC3, cv::Scalar::all(0))), Error);
  EXPECT_THROW(evaluate_segmentation_frame(gt, cv::Mat()), Error);
}

TEST(Segmentation, SummaryAveragesPerLabelOverFramesItAppearsIn) {
  FrameSegmentation a, b;
  a.gt_labels = {{0, 0, 1.0, 10, 10, 10}, {1, 2, 0.5, 4, 4, 2}};
  b.gt_labels = {{0, 0, 0.8, 10, 10, 8}, {2, -1, 0.0, 3, 0, 0}};
  b.unmatched_est_labels = {5, 6};
  const SegmentationSummary s = summarize_segmentation({"a", "b"}, {a, b});
  ASSERT_EQ(s.labels.size(), 3u);
  EXPECT_DOUBLE_EQ(s.labels[0].mean_iou, 0.9);
  EXPECT_EQ(s.labels[0].frames, 2u);
  EXPECT_DOUBLE_EQ(s.labels[1].mean_iou, 0.5);
  EXPECT_EQ(s.labels[2].frames_matched, 0u);
  EXPECT_DOUBLE_EQ(s.mean_label_iou, (0.9 + 0.5 + 0.0) / 3.0);
  EXPECT_EQ(s.unmatched_est_labels, 2u);
}

TEST(Segmentation, FolderEvaluationPairsByFileName) {
  const auto dir = test::fresh_temp_dir();
  const auto gt_dir = dir / "gt", est_dir = dir / "est";
  std::filesystem::create_directories(gt_dir);
  std::filesystem::create_directories(est_dir);
  const cv::Mat gt = labels(2, 2, {0, 0, 1, 1});
  const cv::Mat est = labels(2, 2, {0, 0, 0, 4});
  ASSERT_TRUE(cv::imwrite((gt_dir / "000.png").string(), gt));
  ASSERT_TRUE(cv::imwrite((gt_dir / "001.png").string(), gt));
  ASSERT_TRUE(cv::imwrite((est_dir / "000.png").string(), est));
  const SegmentationSummary s = evaluate_segmentation_dirs(gt_dir, est_dir);
  EXPECT_EQ(s.frames.size(), 1u);
  EXPECT_EQ(s.frames_without_estimate, 1u);
  ASSERT_EQ(s.labels.size(), 2u);
  EXPECT_DOUBLE_EQ(s.labels[0].mean_iou, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(s.labels[1].mean_iou, 0.5);

  EXPECT_THROW(evaluate_segmentation_dirs(dir / "nope", est_dir), Error);
  std::filesystem::create_directories(dir / "other");
  ASSERT_TRUE(cv::imwrite((dir / "other" / "xyz.png").string(), est));
  EXPECT_THROW(evaluate_segmentation_dirs(gt_dir, dir / "other"), Error);
  // A corrupt image names its file.
  { std::ofstream(est_dir / "001.png") << "not a png"; }
  try {
    evaluate_segmentation_dirs(gt_dir, est_dir);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("001.png"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cofusion::eval
