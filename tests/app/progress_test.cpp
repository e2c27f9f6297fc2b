// The progress lines of `cofusion run`: what they say and that they fit the terminal.
#include "commands/progress.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace cofusion::commands {
namespace {
using ::testing::HasSubstr;

ProgressInfo info() {
  return {.processed = 37,
          .read = 37,
          .total = 150,
          .fps = 3.8,
          .models = 3,
          .surfels = 41234,
          .inlier_ratio = 0.934,
          .camera_state = "tracking"};
}

TEST(Progress, EtaIsTheFramesLeftAtTheCurrentRate) {
  EXPECT_DOUBLE_EQ(*eta_s(37, 150, 3.8), 113 / 3.8);
  EXPECT_DOUBLE_EQ(*eta_s(150, 150, 3.8), 0.0);
  EXPECT_DOUBLE_EQ(*eta_s(160, 150, 3.8), 0.0) << "never negative";
  EXPECT_FALSE(eta_s(37, std::nullopt, 3.8)) << "a camera: no total";
  EXPECT_FALSE(eta_s(0, 150, 0.0)) << "no rate measured yet";
}

TEST(Progress, DurationsReadAsClockTime) {
  EXPECT_EQ(format_duration(0), "0:00");
  EXPECT_EQ(format_duration(7.4), "0:07");
  EXPECT_EQ(format_duration(59.6), "1:00");
  EXPECT_EQ(format_duration(725), "12:05");
  EXPECT_EQ(format_duration(3723), "1:02:03");
  EXPECT_EQ(format_duration(-3), "0:00");
}

TEST(Progress, StatusLineShowsFrameOfTotalFpsEtaModelsAndTracking) {
  EXPECT_EQ(status_line(info(), 200), "frame 37/150  3.8 fps  ETA 0:30  models 3  camera tracking  surfels 41k");
  ProgressInfo live = info();
  live.total.reset();
  live.camera_state = "lost";
  EXPECT_EQ(status_line(live, 200), "frame 37  3.8 fps  models 3  camera lost  surfels 41k");
}

TEST(Progress, StatusLineFitsTheTerminalByDroppingTheLastFields) {
  const std::string full = status_line(info(), 200);
  for (int columns : {80, 60, 50, 40, 30, 20}) {
    const std::string line = status_line(info(), columns);
    EXPECT_LT(static_cast<int>(line.size()), columns) << line;
    EXPECT_EQ(full.rfind(line, 0), 0u) << "a prefix of whole fields: " << line;
    EXPECT_THAT(line, HasSubstr("frame 37/150"));
  }
  EXPECT_EQ(status_line(info(), 40), "frame 37/150  3.8 fps  ETA 0:30");
}

TEST(Progress, PlainLineKeepsTheFormatScriptsRead) {
  EXPECT_EQ(plain_line(info()), "frame 37  3.8 fps  models 3  surfels 41234  camera inliers 93%");
}

}  // namespace
}  // namespace cofusion::commands
