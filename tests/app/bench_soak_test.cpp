// `cofusion bench --soak`: the scene played back and forth, and the figures of each window.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "commands/bench_soak.h"
#include "commands/stage_timer.h"
#include "support/gpu_fixture.h"
#include "support/test_support.h"

namespace cofusion::test {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

// The first and last frames' medians of `bench`'s multi-object figures (issue 22's time-per-frame
// bound), including runs shorter than two windows.
TEST(FirstLastMedians, ComparesTheFirstAndLastWindowsInTimeOrder) {
  std::vector<double> ms;
  for (int i = 0; i < 120; ++i) ms.push_back(i < 50 ? 100.0 + i % 3 : i >= 70 ? 130.0 - i % 5 : 1000.0);
  const auto m = commands::first_last_medians(ms, 50);
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->window, 50u);
  EXPECT_DOUBLE_EQ(m->first_ms, 101.0);  // 100, 101, 102 repeating: 17 x 100, 17 x 101, 16 x 102
  EXPECT_DOUBLE_EQ(m->last_ms, 128.0);   // 130..126 repeating, 10 each
  EXPECT_NEAR(m->change(), 128.0 / 101.0 - 1, 1e-12);

  const auto short_run = commands::first_last_medians({4, 1, 9, 7, 5}, 50);  // half of it each
  ASSERT_TRUE(short_run.has_value());
  EXPECT_EQ(short_run->window, 2u);
  EXPECT_DOUBLE_EQ(short_run->first_ms, 2.5);
  EXPECT_DOUBLE_EQ(short_run->last_ms, 6.0);
  EXPECT_FALSE(commands::first_last_medians({3}, 50).has_value());
  EXPECT_EQ(commands::median_of({}), 0.0);
}

TEST(SoakPingPong, PlaysTheSceneForwardsThenBackwardsWithoutJumps) {
  std::vector<int> played;
  for (long i = 0; i < 10; ++i) played.push_back(commands::ping_pong_frame(i, 4));
  EXPECT_EQ(played, (std::vector<int>{0, 1, 2, 3, 2, 1, 0, 1, 2, 3}));
  for (long i = 0; i < 1000; ++i)  // the camera never jumps: neighbouring frames only
    ASSERT_EQ(std::abs(commands::ping_pong_frame(i + 1, 7) - commands::ping_pong_frame(i, 7)), 1) << i;
  EXPECT_EQ(commands::ping_pong_frame(123456789, 1), 0);
  EXPECT_EQ(commands::ping_pong_frame(119, 120), 119);
  EXPECT_EQ(commands::ping_pong_frame(120, 120), 118);
  EXPECT_EQ(commands::ping_pong_frame(237, 120), 1);
  EXPECT_EQ(commands::ping_pong_frame(238, 120), 0);
  EXPECT_EQ(commands::ping_pong_frame(9999, 120), 9999 - 42 * 238);  // 9999 = 42 round trips + 3
}

TEST(SoakMemory, ReadsThisProcesssResidentMemory) {
  const double before = commands::resident_mib();
  EXPECT_GT(before, 1.0);
  std::vector<char> block(64 << 20, 1);  // touched: resident
  EXPECT_GT(commands::resident_mib(), before + 50.0);
  EXPECT_EQ(block[12345], 1);
}

TEST(SoakCpuTime, CountsThisProcesssWorkNotTheWallClock) {
  // Busy: CPU time grows (within 10 s of wall clock, however loaded the machine).
  const double before = commands::process_cpu_ms();
  volatile double sink = 0;
  const auto start = std::chrono::steady_clock::now();
  while (commands::process_cpu_ms() - before < 30.0 && std::chrono::steady_clock::now() - start < std::chrono::seconds(10))
    sink = sink + 1.0;
  EXPECT_GE(commands::process_cpu_ms() - before, 30.0);
  const double idle_before = commands::process_cpu_ms();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_LT(commands::process_cpu_ms() - idle_before, 50.0);  // asleep: no CPU time (other test threads aside)
}

class BenchSoak : public GpuTest {};

// 40 frames of the first 8 of the room (a round trip is 14 frames): five windows, each with
// figures in sane ranges, and a baseline after the round trip.
TEST_F(BenchSoak, EveryWindowHasSaneFiguresAndTheVerdictComparesAfterTheMapCoveredTheScene) {
  commands::SoakOptions o;
  o.frames = 40;
  o.input = "synthetic:static_room";
  o.source_frames = 8;
  o.half_resolution = true;  // 320x240: quicker
  o.report_every_frames = 8;
  o.print = false;
  const commands::SoakReport r = commands::run_soak(ctx(), o);
  EXPECT_EQ(r.width, 320);
  EXPECT_EQ(r.source_frames, 8);
  EXPECT_EQ(r.covered_after_frames, 14);
  ASSERT_EQ(r.windows.size(), 5u);
  ASSERT_TRUE(r.baseline_window.has_value());
  EXPECT_EQ(*r.baseline_window, 2u) << "the first window starting at or after frame 14";
  for (size_t w = 0; w < r.windows.size(); ++w) {
    const auto& win = r.windows[w];
    SCOPED_TRACE("window " + std::to_string(w));
    EXPECT_EQ(win.first_frame, int(w) * 8);
    EXPECT_EQ(win.end_frame, int(w) * 8 + 8);
    EXPECT_GT(win.ms_per_frame, 0.0);
    EXPECT_GT(win.cpu_ms_per_frame, 0.0);
    EXPECT_GT(win.rss_mib, 10.0);
    EXPECT_LT(win.rss_mib, 16384.0);
    // The background model's buffers alone: 2^19 surfels * (48 + 48 + 4) bytes = 50 MiB.
    EXPECT_GT(win.device_mib, 50.0);
    EXPECT_LT(win.device_mib, 4096.0);
    ASSERT_EQ(win.surfels.size(), 1u);
    EXPECT_EQ(win.surfels[0].first, 0);
    EXPECT_EQ(win.surfels[0].second, win.total_surfels);
    EXPECT_GT(win.total_surfels, 5000u);
    EXPECT_EQ(win.lost_frames, 0);
    EXPECT_GE(win.max_camera_error_m, 0.0);
    EXPECT_LT(win.max_camera_error_m, 0.02);
  }
  EXPECT_TRUE(std::isfinite(r.rss_growth_rel) && std::isfinite(r.ms_growth_rel) && std::isfinite(r.cpu_ms_growth_rel));
  EXPECT_LE(std::abs(r.device_growth_rel), 0.05) << "no buffer grows once the room is mapped";
  const auto j = commands::to_json(r);
  EXPECT_EQ(j["windows"].size(), 5u);
  EXPECT_EQ(j["baseline_window"].get<int>(), 2);
  for (const char* k : {"rss_rel", "device_rel", "ms_per_frame_rel", "cpu_ms_per_frame_rel", "surfels_rel"}) EXPECT_TRUE(j["growth"].contains(k)) << k;
  EXPECT_EQ(j["flat"].get<bool>(), r.flat);
}

TEST_F(BenchSoak, ARunTooShortForTheSceneGivesNoVerdict) {
  commands::SoakOptions o;
  o.frames = 8;
  o.input = "synthetic:static_room";
  o.source_frames = 12;
  o.half_resolution = true;
  o.report_every_frames = 4;
  o.print = false;
  const commands::SoakReport r = commands::run_soak(ctx(), o);
  EXPECT_EQ(r.windows.size(), 2u);
  EXPECT_FALSE(r.baseline_window.has_value());
  EXPECT_TRUE(commands::to_json(r)["baseline_window"].is_null());
}

std::string run_cofusion(const std::string& args, int& exit_code) {
  FILE* pipe = ::popen((cofusion_exe().string() + " " + args + " 2>&1").c_str(), "r");
  std::string out;
  std::array<char, 4096> buffer{};
  while (size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe)) out.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

TEST(BenchSoakCommand, PrintsAWindowLineEveryKFramesAndTheVerdictAndWritesJson) {
  const fs::path json = fresh_temp_dir("soak-json") / "soak.json";
  int code = -1;
  const std::string out = run_cofusion(
      "bench --soak 30 --soak-every 10 --soak-source-frames 6 --soak-half-resolution --json " + json.string(), code);
  ASSERT_EQ(code, 0) << out;
  EXPECT_THAT(out, HasSubstr("soak: 30 frames of synthetic:static_room")) << out;
  EXPECT_THAT(out, HasSubstr("(320x240, 6 frames played back and forth), a window every 10 frames")) << out;
  EXPECT_THAT(out, HasSubstr("ms/frame")) << out;
  EXPECT_THAT(out, HasSubstr("CPU per frame")) << out;
  EXPECT_THAT(out, HasSubstr("verdict: window ending at frame 20")) << out;
  EXPECT_THAT(out, HasSubstr("resident memory")) << out;
  EXPECT_THAT(out, HasSubstr("device memory")) << out;
  EXPECT_THAT(out, ::testing::Not(HasSubstr("pipeline full resolution"))) << "--soak runs the soak alone";
  std::ifstream in(json);
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["windows"].size(), 3u);
  EXPECT_EQ(j["windows"][2]["end_frame"].get<int>(), 30);
}

}  // namespace
}  // namespace cofusion::test
