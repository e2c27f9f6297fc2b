// Articulated people and covered-lens occlusions in synthetic scenes: a person's limbs move
// against its pelvis in a walking gait (so the body is not rigid), every part carries the person's
// one instance id, the pelvis follows the keyframed floor path facing its direction of travel with
// a foot on the floor, covered frames have no depth, and the scenes built on these (walking_people,
// camera_loss) behave as their descriptions say.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "common/error.h"
#include "support/test_support.h"
#include "synthetic/articulation.h"
#include "synthetic/dataset_writer.h"
#include "synthetic/motion.h"
#include "synthetic/synthetic_source.h"

namespace cofusion::synthetic {
namespace {

using json = nlohmann::json;
constexpr double kDeg = std::numbers::pi / 180;

// One person walking along +x at 1.2 m/s, the camera moving beside it at the same speed, 3 m away
// and looking at it: the pelvis stays (nearly) still in the camera's view, the limbs do not.
json treadmill_scene() {
  return json::parse(R"({
    "frames": 60,
    "noise": false,
    "camera": {"keyframes": [
      {"frame": 0,  "position": [0.0, -3.0, 1.0], "look_at": [0.0, 0.0, 0.9]},
      {"frame": 75, "position": [3.0, -3.0, 1.0], "look_at": [3.0, 0.0, 0.9]}]},
    "room": {"size": [12, 8, 3]},
    "objects": [{"name": "walker", "class": "person", "kind": "person", "height_m": 1.75,
                 "gait": {"step_hz": 1.8, "arm_swing_deg": 30, "leg_swing_deg": 22},
                 "keyframes": [{"frame": 0, "position": [0, 0, 0]}, {"frame": 75, "position": [3, 0, 0]}]}]
  })");
}

SceneDescription scene_from(const json& j) { return parse_scene(j.dump(), "test_scene.json"); }

int part_index(const ObjectDesc& o, const std::string& name) {
  for (size_t i = 0; i < o.parts.size(); ++i)
    if (o.parts[i].name == name) return static_cast<int>(i);
  ADD_FAILURE() << "no part " << name;
  return 0;
}

// How far a limb's downward axis leans forward (x of the pelvis frame): sin of its swing angle.
double forward_lean(const Pose& T_pelvis_limb) { return -T_pelvis_limb.linear().col(2).x(); }

double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const double n = static_cast<double>(a.size());
  double ma = 0, mb = 0;
  for (size_t i = 0; i < a.size(); ++i) ma += a[i] / n, mb += b[i] / n;
  double ab = 0, aa = 0, bb = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    ab += (a[i] - ma) * (b[i] - mb);
    aa += (a[i] - ma) * (a[i] - ma);
    bb += (b[i] - mb) * (b[i] - mb);
  }
  return ab / std::sqrt(aa * bb);
}

double yaw_of(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

double angle_between(double a, double b) { return std::abs(std::remainder(a - b, 2 * std::numbers::pi)); }

double fraction_of(const cv::Mat& ids, int id) {
  return static_cast<double>(cv::countNonZero(ids == id)) / static_cast<double>(ids.total());
}

TEST(SyntheticPerson, ParsesIntoBodyParts) {
  const SceneDescription s = scene_from(treadmill_scene());
  ASSERT_EQ(s.objects.size(), 1u);
  const ObjectDesc& p = s.objects[0];
  EXPECT_EQ(p.kind, ObjectKind::kPerson);
  EXPECT_DOUBLE_EQ(p.person.height_m, 1.75);
  EXPECT_DOUBLE_EQ(p.person.gait.arm_swing_deg, 30);
  EXPECT_EQ(p.parts.size(), 17u);
  for (const char* name : {"pelvis", "torso", "neck", "head", "left_upper_arm", "right_forearm", "left_hand",
                           "right_thigh", "left_shank", "right_foot"})
    part_index(p, name);
  // Standing at rest: the head's top (hair) is at the person's height above the floor, the soles on it.
  SyntheticSequence seq(s);
  const Mesh m = seq.mesh(1);
  double top = -1e9, bottom = 1e9;
  for (const auto& v : m.positions) top = std::max(top, double(v.z())), bottom = std::min(bottom, double(v.z()));
  EXPECT_NEAR(top - bottom, 1.75, 0.01);
  EXPECT_NEAR(bottom, -0.53 * 1.75, 0.01);  // pelvis frame: origin at hip height
}

TEST(SyntheticPerson, LimbsSwingInAWalkingGait) {
  const SceneDescription s = scene_from(treadmill_scene());
  SyntheticSequence seq(s);
  const ObjectDesc& p = s.objects[0];
  const int lt = part_index(p, "left_thigh"), rt = part_index(p, "right_thigh");
  const int la = part_index(p, "left_upper_arm"), ra = part_index(p, "right_upper_arm");
  const int torso = part_index(p, "torso"), lk = part_index(p, "left_shank");
  std::vector<double> left_leg, right_leg, left_arm, right_arm, torso_yaw, knee;
  for (int f = 10; f < 60; ++f) {  // walking at full speed (the first 0.25 s ramp up)
    const std::vector<Pose> T = seq.T_object_parts(1, f);
    ASSERT_EQ(T.size(), p.parts.size());
    left_leg.push_back(forward_lean(T[lt]));
    right_leg.push_back(forward_lean(T[rt]));
    left_arm.push_back(forward_lean(T[la]));
    right_arm.push_back(forward_lean(T[ra]));
    torso_yaw.push_back(yaw_of(T[torso].linear()));
    knee.push_back(std::acos(std::clamp(T[lt].linear().col(2).dot(T[lk].linear().col(2)), -1.0, 1.0)));
  }
  const auto [lmin, lmax] = std::minmax_element(left_leg.begin(), left_leg.end());
  EXPECT_NEAR(*lmax, std::sin(22 * kDeg), 0.02);  // the full swing each way
  EXPECT_NEAR(*lmin, -std::sin(22 * kDeg), 0.02);
  const auto [amin, amax] = std::minmax_element(left_arm.begin(), left_arm.end());
  EXPECT_GT(*amax - *amin, 2 * std::sin(25 * kDeg));
  EXPECT_LT(correlation(left_leg, right_leg), -0.95);  // legs alternate
  EXPECT_LT(correlation(left_leg, left_arm), -0.95);   // each arm swings against its leg
  EXPECT_GT(correlation(left_leg, right_arm), 0.95);
  const auto [ymin, ymax] = std::minmax_element(torso_yaw.begin(), torso_yaw.end());
  EXPECT_GT(*ymax - *ymin, 8 * kDeg);  // the chest turns with the stride (6 degrees each way)
  EXPECT_LT(*ymax - *ymin, 15 * kDeg);
  const auto [kmin, kmax] = std::minmax_element(knee.begin(), knee.end());
  EXPECT_GT(*kmax, 40 * kDeg);  // the knee bends in the swing and straightens in the stance
  EXPECT_LT(*kmin, 10 * kDeg);
  // One stride (both steps) takes 2 / step_hz seconds: then every limb is back where it was.
  for (double t = 0.4; t < 1.1; t += 0.1) {  // walking at full speed from t - 0.25 to t + 1.36 s
    const std::vector<Pose> now = part_poses(p, t), later = part_poses(p, t + 2 / 1.8);
    for (size_t i = 0; i < now.size(); ++i) ASSERT_TRUE(now[i].isApprox(later[i], 1e-9)) << p.parts[i].name;
  }
}

// The parts' poses are not one rigid motion of the first frame's: the best rigid fit of the part
// centres leaves residuals of limb size.
TEST(SyntheticPerson, BodyIsNotRigid) {
  SyntheticSequence seq(scene_from(treadmill_scene()));
  auto centres = [&](int f) {
    const std::vector<Pose> T = seq.T_object_parts(1, f);
    Eigen::Matrix3Xd c(3, T.size());
    for (size_t i = 0; i < T.size(); ++i) c.col(static_cast<Eigen::Index>(i)) = (*seq.T_world_object(1, f) * T[i]).translation();
    return c;
  };
  const Eigen::Matrix3Xd a = centres(15);
  for (int f : {20, 24, 33}) {
    const Eigen::Matrix3Xd b = centres(f);
    const Eigen::Matrix4d fit = Eigen::umeyama(a, b, false);
    const Eigen::Matrix3Xd moved = (fit.topLeftCorner<3, 3>() * a).colwise() + fit.topRightCorner<3, 1>();
    EXPECT_GT((moved - b).colwise().norm().maxCoeff(), 0.1) << "frame " << f;
  }
  // The pelvis itself stays level and upright; only its height follows the stride, by centimetres
  // about the standing hip height (0.53 of the body height).
  double low = 1e9, high = -1e9;
  for (int f = 0; f < 60; ++f) {
    const Pose T = *seq.T_world_object(1, f);
    EXPECT_NEAR(T.linear().col(2).z(), 1.0, 1e-9);
    low = std::min(low, T.translation().z());
    high = std::max(high, T.translation().z());
  }
  EXPECT_GT(low, 0.48 * 1.75);
  EXPECT_LT(high, 0.54 * 1.75);
  EXPECT_GT(high - low, 0.02);  // people's centre of mass rises and falls 4-6 cm
  EXPECT_LT(high - low, 0.07);
}

// Seen from a camera that keeps pace with the walker, the pelvis hardly moves in the image but the
// silhouette changes shape with the stride; every pixel of the body carries instance id 1.
TEST(SyntheticPerson, SilhouetteChangesAndAllPartsShareOneInstanceId) {
  SyntheticSequence seq(scene_from(treadmill_scene()));
  const ObjectDesc& person = seq.scene().objects[0];
  const RenderedFrame a = seq.render(20, true), b = seq.render(29, true);
  const cv::Mat ma = a.instance_ids == 1, mb = b.instance_ids == 1;
  const int area = cv::countNonZero(ma);
  EXPECT_GT(area, 10000);
  cv::Mat changed;
  cv::bitwise_xor(ma, mb, changed);
  EXPECT_GT(cv::countNonZero(changed), area / 8) << "the silhouette should change with the stride";
  const Pose T_camera_pelvis_a = seq.T_world_camera(20).inverse() * *seq.T_world_object(1, 20);
  const Pose T_camera_pelvis_b = seq.T_world_camera(29).inverse() * *seq.T_world_object(1, 29);
  EXPECT_LT((T_camera_pelvis_a.translation() - T_camera_pelvis_b.translation()).norm(), 0.05);

  // Which part each person pixel lies on (its surface point in the pelvis frame against every
  // part's surface); background pixels must lie on none of them.
  for (const RenderedFrame* r : {&a, &b}) {
    const int frame = r == &a ? 20 : 29;
    const std::vector<Pose> T_object_parts = seq.T_object_parts(1, frame);
    const Pose T_pelvis_world = seq.T_world_object(1, frame)->inverse();
    const auto& parts = seq.renderer().object_parts()[0];
    std::vector<int> pixels_of_part(parts.size(), 0);
    int background_on_person = 0;
    double max_id = 0;
    cv::minMaxLoc(r->instance_ids, nullptr, &max_id);
    EXPECT_EQ(max_id, 1);
    for (int v = 0; v < r->instance_ids.rows; ++v)
      for (int u = 0; u < r->instance_ids.cols; ++u) {
        const int id = r->instance_ids.at<uint16_t>(v, u);
        const cv::Vec3f w = r->points_world.at<cv::Vec3f>(v, u);
        const Eigen::Vector3d p = T_pelvis_world * Eigen::Vector3d(w[0], w[1], w[2]);
        int on = -1;
        for (size_t i = 0; i < parts.size() && on < 0; ++i)
          if (std::abs(parts[i].signed_distance(T_object_parts[i].inverse() * p)) < 1e-3) on = static_cast<int>(i);
        if (id == 1) {
          ASSERT_GE(on, 0) << "person pixel " << u << "," << v << " on no part";
          ++pixels_of_part[on];
        } else if (on >= 0 && w[2] > 1e-3f) {  // the soles touch the floor: skip floor points
          ++background_on_person;
        }
      }
    EXPECT_EQ(background_on_person, 0);
    // Seen from the side: at least the near arm, both legs, torso, pelvis, head, feet show.
    int seen = 0;
    for (size_t i = 0; i < parts.size(); ++i) seen += pixels_of_part[i] > 20;
    EXPECT_GE(seen, 11) << "frame " << frame;
    for (const char* name : {"torso", "head", "left_thigh", "right_shank", "left_foot", "pelvis"})
      EXPECT_GT(pixels_of_part[part_index(person, name)], 20) << name << ", frame " << frame;
  }
}

TEST(SyntheticPerson, WalksAlongItsPathFacingTheWayItGoes) {
  SyntheticSequence seq(load_scene("walking_people"));
  ASSERT_EQ(seq.object_count(), 3);
  for (int id = 1; id <= 3; ++id) {
    const ObjectDesc& o = seq.scene().objects[id - 1];
    SCOPED_TRACE(o.name);
    ASSERT_EQ(o.kind, ObjectKind::kPerson);
    const int foot_l = part_index(o, "left_foot"), foot_r = part_index(o, "right_foot");
    for (int f = o.first_frame; f <= o.last_frame; ++f) {
      const Pose T = *seq.T_world_object(id, f);
      // On the keyframed floor path, at hip height.
      const Eigen::Vector3d floor = interpolate(o.path, seq.timestamp_s(f)).translation();
      ASSERT_LT((T.translation().head<2>() - floor.head<2>()).norm(), 1e-9) << "frame " << f;
      ASSERT_GT(T.translation().z() - floor.z(), 0.48 * o.person.height_m);
      ASSERT_LT(T.translation().z() - floor.z(), 0.54 * o.person.height_m);
      // Facing the direction of travel (measured over +-3 frames of ground truth). Straight paths:
      // within a degree; around walker_turning's corner the heading is smoothed over half a second.
      if (f - 3 >= o.first_frame && f + 3 <= o.last_frame) {
        const Eigen::Vector3d d = seq.T_world_object(id, f + 3)->translation() - seq.T_world_object(id, f - 3)->translation();
        const double travel_yaw = std::atan2(d.y(), d.x());
        const double tolerance = o.name == "walker_turning" ? 20 * kDeg : 1 * kDeg;
        EXPECT_LT(angle_between(yaw_of(T.linear()), travel_yaw), tolerance) << "frame " << f;
        EXPECT_GT(d.head<2>().norm() / 0.2, 0.9) << "walking speed, frame " << f;
        EXPECT_LT(d.head<2>().norm() / 0.2, 1.4) << "walking speed, frame " << f;
      }
      // The lower foot stands on the floor.
      const std::vector<Pose> parts = seq.T_object_parts(id, f);
      double lowest = 1e9;
      for (int i : {foot_l, foot_r}) {
        const Eigen::Vector3d half = o.parts[i].shape.size_m / 2;
        for (int c = 0; c < 8; ++c) {
          const Eigen::Vector3d corner((c & 1 ? 1 : -1) * half.x(), (c & 2 ? 1 : -1) * half.y(), (c & 4 ? 1 : -1) * half.z());
          lowest = std::min(lowest, (T * parts[i] * corner).z());
        }
      }
      ASSERT_NEAR(lowest, floor.z(), 1e-6) << "frame " << f;
    }
  }
  // walker_turning turns from walking along +y (to the image's left) to walking away along +x.
  const int turning = 3;
  EXPECT_LT(angle_between(yaw_of(seq.T_world_object(turning, 50)->linear()), 90 * kDeg), 1 * kDeg);
  EXPECT_LT(angle_between(yaw_of(seq.T_world_object(turning, 110)->linear()), std::atan2(0.15, 1.2)), 1 * kDeg);
}

TEST(SyntheticPerson, KeyRotationsOverrideTheHeadingAndStandingStillStopsTheGait) {
  json j = treadmill_scene();
  j["objects"][0]["keyframes"] = json::parse(R"([
    {"frame": 0,  "position": [0, 0, 0]},
    {"frame": 20, "position": [0, 0, 0]},
    {"frame": 50, "position": [1.2, 0, 0]}])");
  SyntheticSequence seq(scene_from(j));
  const ObjectDesc& p = seq.scene().objects[0];
  // Standing before it sets off: limbs hang straight, facing the way it will go (+x).
  const int lt = part_index(p, "left_thigh");
  EXPECT_NEAR(forward_lean(seq.T_object_parts(1, 5)[lt]), 0.0, 1e-9);
  EXPECT_NEAR(yaw_of(seq.T_world_object(1, 5)->linear()), 0.0, 1e-9);
  EXPECT_NEAR(seq.T_world_object(1, 5)->translation().z(), 0.53 * 1.75, 1e-9);
  // With a rotation on the keys, the body follows the keys' rotation instead of the path.
  j["objects"][0]["keyframes"][2]["rotation"] = {{"axis", {0, 0, 1}}, {"angle_deg", 90}};
  SyntheticSequence rotated(scene_from(j));
  EXPECT_NEAR(yaw_of(rotated.T_world_object(1, 50)->linear()), 90 * kDeg, 1e-9);
  EXPECT_NEAR(yaw_of(rotated.T_world_object(1, 35)->linear()), 45 * kDeg, 1e-9);
}

TEST(SyntheticPerson, BadPersonFieldsAreNamed) {
  auto error_with = [](const std::function<void(json&)>& edit) {
    json j = treadmill_scene();
    edit(j);
    return test::error_of([&] { scene_from(j); });
  };
  EXPECT_NE(error_with([](json& j) { j["objects"][0]["kind"] = "robot"; }).find("objects[0].kind: unknown object kind"),
            std::string::npos);
  EXPECT_NE(error_with([](json& j) { j["objects"][0]["shape"] = "box"; }).find("objects[0].shape: a person has no shape"),
            std::string::npos);
  EXPECT_NE(error_with([](json& j) { j["objects"][0]["texture"] = {{"type", "solid"}, {"colors", {{1, 2, 3}}}}; })
                .find("objects[0].texture: a person's colours are given by 'clothes'"),
            std::string::npos);
  EXPECT_NE(error_with([](json& j) { j["objects"][0]["height_m"] = 3.5; }).find("objects[0].height_m: must be in"),
            std::string::npos);
  EXPECT_NE(error_with([](json& j) { j["objects"][0]["gait"]["stride"] = 1; }).find("objects[0].gait.stride: unknown field"),
            std::string::npos);
  EXPECT_NE(error_with([](json& j) { j["objects"][0]["clothes"] = {{"hat", 1}}; }).find("objects[0].clothes.hat: unknown field"),
            std::string::npos);
  EXPECT_NE(error_with([](json& j) { j["occlusions"] = {{{"frames", {5, 2}}}}; })
                .find("occlusions[0].frames: expected [first, last]"),
            std::string::npos);
  EXPECT_NE(error_with([](json& j) { j["occlusions"] = {{{"frames", {1, 2}}, {"kind", "fog"}}}; })
                .find("occlusions[0].kind: unknown occlusion kind"),
            std::string::npos);
}

TEST(SyntheticOcclusion, CoveredFramesHaveNoDepthAndADarkImage) {
  SyntheticSequence seq(load_scene("camera_loss"));
  ASSERT_EQ(seq.scene().occlusions.size(), 1u);
  for (int f : {29, 30, 45, 59, 60}) {
    SCOPED_TRACE("frame " + std::to_string(f));
    const bool covered = f >= 30 && f <= 59;
    EXPECT_EQ(seq.covered(f), covered);
    const Frame frame = seq.frame(f);
    ASSERT_TRUE(frame.T_world_camera_gt.has_value());
    EXPECT_TRUE(frame.T_world_camera_gt->isApprox(seq.T_world_camera(f)));
    cv::Scalar mean, stddev;
    cv::meanStdDev(frame.rgb, mean, stddev);
    if (covered) {
      EXPECT_EQ(cv::countNonZero(frame.depth_m), 0);
      EXPECT_EQ(cv::countNonZero(frame.mask), 0);
      EXPECT_LT(mean[0] + mean[1] + mean[2], 3 * 20.0);  // nearly black
      EXPECT_GT(stddev[1], 1.0);                          // but with sensor noise
    } else {
      EXPECT_GT(cv::countNonZero(frame.depth_m), 0.7 * frame.depth_m.total());
      EXPECT_GT(mean[0] + mean[1] + mean[2], 3 * 60.0);
    }
  }
  const RenderedFrame r = seq.render(40, true);
  EXPECT_EQ(cv::countNonZero(r.depth_true_m), 0);
  EXPECT_EQ(cv::countNonZero(r.cos_incidence), 0);
  EXPECT_EQ(cv::countNonZero(r.points_world.reshape(1)), 0);
  // The camera moves on behind the hand: the view it comes back to is not the one it lost.
  const Pose lost = seq.T_world_camera(29), back = seq.T_world_camera(60);
  EXPECT_GT((lost.translation() - back.translation()).norm(), 0.2);
  // Frames render independently: a covered frame does not depend on having rendered others.
  EXPECT_EQ(cv::norm(seq.render(45).rgb, SyntheticSequence(load_scene("camera_loss")).render(45).rgb, cv::NORM_INF), 0);
}

TEST(SyntheticOcclusion, WhipPanTurnsAboutNinetyDegreesInSixFramesAndBack) {
  SyntheticSequence seq(load_scene("camera_loss"));
  auto rotation_deg = [&](int a, int b) {
    return Eigen::AngleAxisd(seq.T_world_camera(a).linear().transpose() * seq.T_world_camera(b).linear()).angle() / kDeg;
  };
  EXPECT_GT(rotation_deg(85, 91), 80);
  EXPECT_LT(rotation_deg(85, 91), 100);
  EXPECT_LT(rotation_deg(85, 100), 3);  // back where it was (up to the hand-held shake)
  double fastest = 0;
  for (int f = 85; f < 100; ++f) fastest = std::max(fastest, rotation_deg(f, f + 1));
  EXPECT_GT(fastest, 15);
  // Outside the pan the camera moves at hand-held speed.
  for (int f = 0; f + 1 < seq.size(); ++f)
    if (f < 85 || f >= 100) {
      EXPECT_LT(rotation_deg(f, f + 1), 2) << "frame " << f;
    }
  // It still sees the room while turned away from the table.
  const RenderedFrame r = seq.render(92);
  EXPECT_GT(cv::countNonZero(r.depth_m), 0.7 * r.depth_m.total());
}

// The two scenes at a quarter of the resolution (160x120): the people enter and leave the view,
// cover a large part of it at times, and the dataset writer labels them as people.
SceneDescription quarter_resolution(SceneDescription s) {
  s.camera.intrinsics = s.camera.intrinsics.at_level(2);
  return s;
}

TEST(SyntheticPerson, WalkingPeopleEnterCoverAndLeaveTheView) {
  SyntheticSequence seq(quarter_resolution(load_scene("walking_people")));
  seq.set_noise(KinectNoiseParams::none());
  ASSERT_EQ(seq.intrinsics().width, 160);
  std::vector<double> best(4, 0.0);
  double most_covered = 0;
  for (int f = 0; f < seq.size(); f += 3) {
    const cv::Mat ids = seq.render(f).instance_ids;
    for (int id = 1; id <= 3; ++id) best[id] = std::max(best[id], fraction_of(ids, id));
    most_covered = std::max(most_covered, fraction_of(ids, 1) + fraction_of(ids, 2) + fraction_of(ids, 3));
  }
  for (int id = 1; id <= 3; ++id) EXPECT_GT(best[id], 0.04) << "person " << id;
  EXPECT_GT(most_covered, 0.3);
  EXPECT_LT(most_covered, 0.6);
  // Out of view when they appear and (the two who cross the room) when they go.
  for (int id = 1; id <= 3; ++id) {
    const ObjectInfo o = seq.objects()[id - 1];
    EXPECT_EQ(fraction_of(seq.render(o.first_frame).instance_ids, id), 0.0) << "person " << id << " pops in";
    if (id != 3) {
      EXPECT_EQ(fraction_of(seq.render(o.last_frame).instance_ids, id), 0.0) << "person " << id << " pops out";
    }
  }
}

TEST(SyntheticPerson, DatasetListsPeopleAndTheirPelvisTrajectories) {
  const auto dir = test::fresh_temp_dir() / "wp";
  SyntheticSequence seq(quarter_resolution(load_scene("walking_people")), 0, 25);
  write_tum_dataset(seq, dir);
  std::ifstream objects(dir / "objects.txt");
  std::string line;
  int people = 0;
  while (std::getline(objects, line)) people += line.find(" person ") != std::string::npos;
  EXPECT_EQ(people, 3);
  std::ifstream gt(dir / "groundtruth-3.txt");
  std::stringstream text;
  text << gt.rdbuf();
  EXPECT_NE(text.str().find("pelvis"), std::string::npos);
  int poses = 0;
  for (std::istringstream in(text.str()); std::getline(in, line);) poses += !line.empty() && line[0] != '#';
  EXPECT_EQ(poses, 5);  // walker_turning appears at frame 20
  EXPECT_TRUE(std::filesystem::exists(dir / "geometry" / "object-1.glb"));
}

}  // namespace
}  // namespace cofusion::synthetic
