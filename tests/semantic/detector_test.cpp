// The converted networks on real frames, and the converter's determinism. These need the models
// that .ci/fetch-models.sh converts into $COFUSION_MODELS (build/models) and the recordings in
// $COFUSION_DATA; each case skips with a message when they are absent.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "semantic/detector.h"
#include "semantic/instance_masks.h"
#include "support/test_support.h"

namespace cofusion::semantic {
namespace {
namespace fs = std::filesystem;

std::optional<fs::path> model(const std::string& file) {
  const char* env = std::getenv("COFUSION_MODELS");
  if (env == nullptr || *env == '\0') return std::nullopt;
  const fs::path p = fs::path(env) / file;
  return fs::is_regular_file(p) ? std::optional(p) : std::nullopt;
}

// The first frame of a TUM folder (sorted rgb/ and depth/ names).
fs::path first_file(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files.empty() ? fs::path() : files.front();
}

cv::Mat read_rgb(const fs::path& file) {
  cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR), rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

double iou(const cv::Rect2f& a, const cv::Rect2f& b) {
  const float inter = (a & b).area();
  return inter / (a.area() + b.area() - inter);
}

std::string bytes_of(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

#define REQUIRE_MODEL(var, file)                                                          \
  const auto var = model(file);                                                           \
  if (!var) GTEST_SKIP() << file << " not in $COFUSION_MODELS: run .ci/fetch-models.sh"

TEST(Detector, MissingModelNamesTheFileAndTheFix) {
  const std::string e = test::error_of([] { Detector d("/nonexistent/centernet.pb"); });
  EXPECT_NE(e.find("/nonexistent/centernet.pb"), std::string::npos) << e;
  EXPECT_NE(e.find(".ci/fetch-models.sh"), std::string::npos) << e;
  EXPECT_NE(test::error_of([] { PersonSegmenter s("/nonexistent/selfie.pb"); }).find("fetch-models"), std::string::npos);
}

TEST(Detector, FindsTheDeskObjectsOfTumFr2Desk) {
  REQUIRE_MODEL(pb, "centernet.pb");
  const auto data = test::data_dir("tum_fr2_desk_50");
  if (!data) GTEST_SKIP() << "tum_fr2_desk_50 not in $COFUSION_DATA";
  const cv::Mat rgb = read_rgb(first_file(*data / "rgb"));
  ASSERT_EQ(rgb.size(), cv::Size(640, 480));
  Detector detector(*pb);
  const auto dets = detector.detect(rgb);
  double total_ms = 0;
  for (int i = 0; i < 3; ++i) {
    (void)detector.detect(rgb);
    total_ms += detector.last_forward_ms();
  }
  std::printf("centernet forward pass: %.0f ms (mean of 3 after a warm-up)\n", total_ms / 3);
  for (const auto& d : dets)
    std::printf("  %-12s %.2f  x %.0f..%.0f  y %.0f..%.0f\n", d.class_name.c_str(), d.score, d.box_px.x,
                d.box_px.x + d.box_px.width, d.box_px.y, d.box_px.y + d.box_px.height);
  // What is on the desk in the first frame (boxes measured once, by eye checked on the image).
  struct Expected {
    const char* name;
    cv::Rect2f box;
  };
  const Expected expected[] = {
      {"tvmonitor", cv::Rect2f(cv::Point2f(238, 100), cv::Point2f(388, 230))},
      {"keyboard", cv::Rect2f(cv::Point2f(199, 260), cv::Point2f(379, 304))},
      {"mouse", cv::Rect2f(cv::Point2f(377, 319), cv::Point2f(408, 358))},
      {"cup", cv::Rect2f(cv::Point2f(441, 289), cv::Point2f(491, 352))},
  };
  for (const auto& e : expected) {
    double best = 0;
    for (const auto& d : dets)
      if (d.class_name == e.name) best = std::max(best, iou(d.box_px, e.box));
    EXPECT_GE(best, 0.7) << e.name << ": no detection overlapping its expected box";
  }
  for (const auto& d : dets) EXPECT_GE(d.score, detector.params().score_threshold);
}

TEST(Detector, InstanceMasksOfTheDeskObjects) {
  REQUIRE_MODEL(pb, "centernet.pb");
  const auto data = test::data_dir("tum_fr2_desk_50");
  if (!data) GTEST_SKIP() << "tum_fr2_desk_50 not in $COFUSION_DATA";
  const cv::Mat rgb = read_rgb(first_file(*data / "rgb"));
  cv::Mat depth_raw = cv::imread(first_file(*data / "depth").string(), cv::IMREAD_UNCHANGED), depth_m;
  ASSERT_EQ(depth_raw.type(), CV_16UC1);
  depth_raw.convertTo(depth_m, CV_32FC1, 1.0 / 5000.0);  // TUM: 5000 units per metre
  Intrinsics k;  // TUM fr2
  k.fx = 520.9;
  k.fy = 521.0;
  k.cx = 325.1;
  k.cy = 249.7;
  Detector detector(*pb);
  const auto masks = instance_masks(detector.detect(rgb), depth_m, k, {});
  const Instance* keyboard = nullptr;
  const Instance* cup = nullptr;
  for (const auto& inst : masks.instances) {
    std::printf("  %2d %-12s %.2f  %6d pixels of a %6.0f-pixel box\n", inst.id, inst.class_name.c_str(), inst.score,
                inst.pixels, inst.box_px.area());
    if (inst.class_name == "keyboard" && !keyboard) keyboard = &inst;
    if (inst.class_name == "cup" && !cup) cup = &inst;
  }
  ASSERT_TRUE(keyboard != nullptr);
  ASSERT_TRUE(cup != nullptr);
  // The keyboard's box is mostly keyboard, the desk around it is cut off; the cup's box holds
  // the cup and the desk under and behind it.
  EXPECT_GT(keyboard->pixels, 0.3 * keyboard->box_px.area());
  EXPECT_LT(keyboard->pixels, 0.95 * keyboard->box_px.area());
  EXPECT_GT(cup->pixels, 0.3 * cup->box_px.area());
  EXPECT_LT(cup->pixels, 0.95 * cup->box_px.area());
  // Every instance's pixels lie in its box.
  for (int y = 0; y < masks.ids.rows; ++y)
    for (int x = 0; x < masks.ids.cols; ++x)
      if (const uint16_t id = masks.ids.at<uint16_t>(y, x); id != 0) {
        const cv::Rect2f& b = masks.instances[id - 1u].box_px;
        ASSERT_TRUE(x + 1 > b.x && x < b.x + b.width && y + 1 > b.y && y < b.y + b.height) << x << "," << y;
      }
}

TEST(PersonSegmenter, MarksThePersonOfBonnCrowd) {
  REQUIRE_MODEL(selfie, "selfie.pb");
  REQUIRE_MODEL(pb, "centernet.pb");
  const auto data = test::data_dir("bonn_crowd_first_half");
  if (!data) GTEST_SKIP() << "bonn_crowd_first_half not in $COFUSION_DATA";
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(*data / "rgb")) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  ASSERT_GT(files.size(), 2u);
  const cv::Mat rgb = read_rgb(files[files.size() / 2]);
  PersonSegmenter segmenter(*selfie);
  const cv::Mat prob = segmenter.segment(rgb);
  ASSERT_EQ(prob.size(), rgb.size());
  ASSERT_EQ(prob.type(), CV_32FC1);
  std::printf("selfie forward pass: %.0f ms\n", segmenter.last_forward_ms());
  Detector detector(*pb);
  const auto dets = detector.detect(rgb);
  const Detection* person = nullptr;
  for (const auto& d : dets)
    if (d.class_id == 0 && (!person || d.score > person->score)) person = &d;
  ASSERT_TRUE(person != nullptr) << "the detector sees the person";
  const cv::Rect box = cv::Rect(person->box_px) & cv::Rect(0, 0, rgb.cols, rgb.rows);
  const double inside = cv::countNonZero(prob(box) > 0.5) / static_cast<double>(box.area());
  cv::Mat outside_mask(prob.size(), CV_8UC1, cv::Scalar(255));
  outside_mask(box).setTo(0);
  const double outside = cv::countNonZero((prob > 0.5) & outside_mask) / static_cast<double>(cv::countNonZero(outside_mask));
  std::printf("person box: %.0f%% marked as person inside, %.1f%% outside\n", 100 * inside, 100 * outside);
  EXPECT_GT(inside, 0.2) << "the selfie model marks the upper body; the legs hardly";
  EXPECT_LT(outside, 0.05);
}

TEST(Converter, IsDeterministicAndMatchesTheFetchedGraph) {
  REQUIRE_MODEL(pb, "centernet.pb");
  const fs::path models = pb->parent_path();
  if (!fs::is_regular_file(models / "tfjs/centernet.json") || !fs::is_regular_file(models / "proto/tf_graph_pb2.py"))
    GTEST_SKIP() << "the TF.js files or the generated protobuf module are not in " << models;
  const fs::path tmp = test::fresh_temp_dir();
  const std::string converter = (test::source_dir() / "tools/tfjs_to_graphdef.py").string();
  for (const char* name : {"a.pb", "b.pb"}) {
    const std::string cmd = "/usr/bin/python3 '" + converter + "' --proto-dir '" + (models / "proto").string() +
                            "' '" + (models / "tfjs/centernet.json").string() + "' '" + (tmp / name).string() +
                            "' --output tower_0/keypoints --output tower_0/wh > /dev/null";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  }
  const std::string a = bytes_of(tmp / "a.pb");
  EXPECT_GT(a.size(), 4'000'000u) << "float32 weights of a 4 MB fp16 model";
  EXPECT_TRUE(a == bytes_of(tmp / "b.pb")) << "two conversions differ";
  EXPECT_TRUE(a == bytes_of(*pb)) << "the conversion differs from " << *pb;
  // And what it wrote loads.
  EXPECT_NO_THROW(Detector d(tmp / "a.pb"));
}

}  // namespace
}  // namespace cofusion::semantic
