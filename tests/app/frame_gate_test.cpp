// FrameGate: which frames `cofusion run` skips, what it records and when it gives up.
#include "commands/frame_gate.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "io/source_adaptors.h"
#include "support/test_support.h"

namespace cofusion::commands {
namespace {
using ::testing::HasSubstr;

constexpr int kW = 8, kH = 6;

Intrinsics intrinsics() {
  Intrinsics k;
  k.fx = k.fy = 10;
  k.cx = 3.5;
  k.cy = 2.5;
  k.width = kW;
  k.height = kH;
  return k;
}

Frame frame(float depth_m, int w = kW, int h = kH) {
  Frame f;
  f.rgb = cv::Mat(h, w, CV_8UC3, cv::Scalar::all(100));
  f.depth_m = cv::Mat(h, w, CV_32FC1, cv::Scalar(depth_m));
  return f;
}

std::vector<Frame> frames_with_bad_ones() {
  std::vector<Frame> frames{frame(1.0f), frame(0.0f), frame(1.0f, kW + 1, kH), frame(1.0f)};
  frames[1].depth_m.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();  // NaN is no reading
  return frames;
}

TEST(FrameGate, SkipsFramesWithoutDepthOrOfTheWrongSizeAndRecordsWhy) {
  MemorySource source(frames_with_bad_ones(), intrinsics());
  FrameGate gate(source, intrinsics(), {});
  EXPECT_EQ(gate.next()->index, 0);
  EXPECT_EQ(gate.next()->index, 3);
  EXPECT_FALSE(gate.next());
  ASSERT_EQ(gate.skipped().size(), 2u);
  EXPECT_EQ(gate.skipped()[0].frame, 1);
  EXPECT_THAT(gate.skipped()[0].reason, HasSubstr("no valid depth"));
  EXPECT_EQ(gate.skipped()[1].frame, 2);
  EXPECT_THAT(gate.skipped()[1].reason, HasSubstr("depth is 9x6 but the intrinsics say 8x6"));
}

TEST(FrameGate, StrictFailsAtTheFirstBadFrame) {
  MemorySource source(frames_with_bad_ones(), intrinsics());
  FrameGate gate(source, intrinsics(), {.strict = true});
  EXPECT_EQ(gate.next()->index, 0);
  const std::string msg = test::error_of([&] { gate.next(); });
  EXPECT_THAT(msg, HasSubstr("frame 1: no valid depth"));
  EXPECT_THAT(msg, HasSubstr("--strict"));
}

TEST(FrameGate, GivesUpWhenTheFirstFramesAreAllBad) {
  MemorySource source(std::vector<Frame>(40, frame(0.0f)), intrinsics());
  FrameGate gate(source, intrinsics(), {.max_leading_bad_frames = 30});
  const std::string msg = test::error_of([&] { gate.next(); });
  EXPECT_THAT(msg, HasSubstr("the first 30 frames are all bad"));
  EXPECT_THAT(msg, HasSubstr("frame 0: no valid depth"));
}

TEST(FrameGate, SourceOfOnlyBadFramesFails) {
  MemorySource source(std::vector<Frame>(3, frame(0.0f)), intrinsics());
  FrameGate gate(source, intrinsics(), {});
  EXPECT_THAT(test::error_of([&] { gate.next(); }), HasSubstr("no usable frame: all 3 frames are bad"));
}

TEST(FrameGate, ManyBadFramesAfterAGoodOneAreSkipped) {
  std::vector<Frame> frames(50, frame(0.0f));
  frames.front() = frame(1.0f);
  frames.back() = frame(1.0f);
  MemorySource source(std::move(frames), intrinsics());
  FrameGate gate(source, intrinsics(), {.max_leading_bad_frames = 30});
  EXPECT_EQ(gate.next()->index, 0);
  EXPECT_EQ(gate.next()->index, 49);
  EXPECT_EQ(gate.skipped().size(), 48u);
}

}  // namespace
}  // namespace cofusion::commands
