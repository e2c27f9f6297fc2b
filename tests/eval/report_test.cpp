#include "eval/drift_plot.h"
#include "eval/report.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <tiny_gltf.h>

#include <cstring>
#include <fstream>

#include "common/error.h"
#include "support/test_support.h"

namespace cofusion::eval {
namespace {

namespace fs = std::filesystem;

Pose make_pose(double yaw, double roll, const Eigen::Vector3d& t) {
  Pose T = Pose::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX())).toRotationMatrix();
  T.translation() = t;
  return T;
}

// An object spinning and moving, sampled at 30 Hz for `seconds`.
Trajectory object_trajectory(double phase, double seconds) {
  Trajectory out;
  for (int i = 0; i < static_cast<int>(seconds * 30); ++i) {
    const double t = i / 30.0;
    out.push_back({50 + t, make_pose(phase + 0.8 * t, 0.3 * std::sin(t + phase),
                                     Eigen::Vector3d(std::cos(t + phase), phase + 0.3 * t, 1.0 + 0.1 * std::sin(2 * t)))});
  }
  return out;
}

// The system's view of an object: model frame = world frame at first sight.
Trajectory as_model(const Trajectory& gt_object) {
  Trajectory out = gt_object;
  const Pose first_inv = gt_object.front().T_world_x.inverse();
  for (auto& p : out) p.T_world_x = p.T_world_x * first_inv;
  return out;
}

TEST(TrajectoryReport, ConformanceFilesGiveTheScriptsFigures) {
  const auto dir = test::data_dir("trajectories");
  if (!dir) GTEST_SKIP() << "COFUSION_DATA/trajectories not found";
  const auto e = evaluate_trajectory_files(*dir / "freiburg1_xyz-groundtruth.txt", *dir / "freiburg1_xyz-rgbdslam.txt");
  const std::string text = to_text(e);
  EXPECT_NE(text.find("ate_pairs 786\n"), std::string::npos) << text;
  EXPECT_NE(text.find("ate_rmse_m 0.013473\n"), std::string::npos) << text;
  EXPECT_NE(text.find("ate_median_m 0.011176\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rpe_pairs 753\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rpe_trans_rmse_m 0.021217\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rpe_rot_rmse_deg 0.934480\n"), std::string::npos) << text;
  const nlohmann::json j = to_json(e);
  EXPECT_NEAR(j["ate"]["translation_m"]["rmse"].get<double>(), 0.013473, 1e-5);
  EXPECT_EQ(j["rpe"]["pairs"].get<int>(), 753);
}

TEST(TrajectoryReport, ShortSequenceKeepsAteAndExplainsMissingRpe) {
  const auto dir = test::fresh_temp_dir();
  const Trajectory gt = object_trajectory(0.0, 0.5);
  write_tum_trajectory(dir / "gt.txt", gt);
  write_tum_trajectory(dir / "est.txt", gt);
  const auto e = evaluate_trajectory_files(dir / "gt.txt", dir / "est.txt");
  EXPECT_FALSE(e.rpe.has_value());
  EXPECT_FALSE(e.rpe_error.empty());
  EXPECT_LT(e.ate.translation_m.rmse, 1e-6);
  EXPECT_NE(to_text(e).find("rpe_skipped "), std::string::npos);
  EXPECT_TRUE(to_json(e)["rpe"].contains("error"));
}

TEST(TrajectoryReport, ErrorsNameTheFiles) {
  const auto dir = test::fresh_temp_dir();
  write_tum_trajectory(dir / "gt.txt", object_trajectory(0.0, 1.0));
  Trajectory later = object_trajectory(0.0, 1.0);
  for (auto& p : later) p.timestamp_s += 100;
  write_tum_trajectory(dir / "later.txt", later);
  try {
    evaluate_trajectory_files(dir / "gt.txt", dir / "later.txt");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("later.txt"), std::string::npos) << e.what();
  }
  EXPECT_THROW(evaluate_trajectory_files(dir / "gt.txt", dir / "absent.txt"), Error);
}

TEST(PoseText, SevenOrSixteenNumbers) {
  const Pose a = parse_pose_text("1 2 3 0 0 0.7071067811865476 0.7071067811865476");
  EXPECT_TRUE(a.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE((a * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d(1, 3, 3), 1e-12));
  const Pose b = parse_pose_text("0,-1,0,1, 1,0,0,2, 0,0,1,3, 0,0,0,1");
  EXPECT_TRUE(b.isApprox(a, 1e-12));
  EXPECT_THROW(parse_pose_text("1 2 3"), Error);
  EXPECT_THROW(parse_pose_text("1 2 3 0 0 0 0"), Error);                          // zero quaternion
  EXPECT_THROW(parse_pose_text("2 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"), Error);        // scaled
  EXPECT_THROW(parse_pose_text("1 2 3 0 0 0 one"), Error);
}

TEST(PoseAtTime, NearestWithinTolerance) {
  const Trajectory t = object_trajectory(0.0, 1.0);
  EXPECT_TRUE(pose_at_time(t, 50.0 + 3.0 / 30 + 0.001, 0.02, "x").isApprox(t[3].T_world_x));
  EXPECT_THROW(pose_at_time(t, 10.0, 0.02, "x"), Error);
  EXPECT_THROW(pose_at_time({}, 50.0, 0.02, "x"), Error);
}

TEST(ObjectsReport, AutomaticMatchingFindsSwappedIds) {
  const auto dir = test::fresh_temp_dir();
  fs::create_directories(dir / "gt");
  fs::create_directories(dir / "est");
  const Trajectory a = object_trajectory(0.0, 3.0), b = object_trajectory(1.7, 3.0), c = object_trajectory(3.1, 3.0);
  write_tum_trajectory(dir / "gt" / "groundtruth-1.txt", a);
  write_tum_trajectory(dir / "gt" / "groundtruth-2.txt", b);
  write_tum_trajectory(dir / "gt" / "groundtruth-3.txt", c);  // never found by the system
  // Model ids differ from ground-truth ids; model 7 starts later (first seen at 1 s).
  write_tum_trajectory(dir / "est" / "model-4.txt", as_model(b));
  write_tum_trajectory(dir / "est" / "model-7.txt", as_model(Trajectory(a.begin() + 30, a.end())));
  const ObjectsEvaluation e = evaluate_object_dirs(dir / "gt", dir / "est", std::nullopt);
  ASSERT_EQ(e.pairs.size(), 2u);
  EXPECT_EQ(e.pairs[0].est_id, 4);
  EXPECT_EQ(e.pairs[0].gt_id, 2);
  EXPECT_EQ(e.pairs[1].est_id, 7);
  EXPECT_EQ(e.pairs[1].gt_id, 1);
  for (const auto& p : e.pairs) {
    EXPECT_LT(p.errors.tracked_point_m.rmse, 1e-5);
    EXPECT_GT(p.errors.origin_ate.translation_m.rmse, 1e-3);  // different body points
  }
  EXPECT_EQ(e.unmatched_gt_ids, (std::vector<int>{3}));
  EXPECT_TRUE(e.unmatched_est_ids.empty());
  const std::string text = to_text(e);
  EXPECT_NE(text.find("object model 4 gt 2 pairs 90 "), std::string::npos) << text;
  EXPECT_NE(text.find("unmatched_gt 3\n"), std::string::npos) << text;

  // A fixed mapping is taken as given, even when it is wrong.
  const ObjectsEvaluation fixed = evaluate_object_dirs(dir / "gt", dir / "est", std::map<int, int>{{4, 1}});
  ASSERT_EQ(fixed.pairs.size(), 1u);
  EXPECT_EQ(fixed.pairs[0].gt_id, 1);
  EXPECT_GT(fixed.pairs[0].errors.tracked_point_m.rmse, 0.01);
  EXPECT_EQ(fixed.unmatched_est_ids, (std::vector<int>{7}));
  EXPECT_THROW(evaluate_object_dirs(dir / "gt", dir / "est", std::map<int, int>{{5, 1}}), Error);
  EXPECT_THROW(evaluate_object_dirs(dir / "gt", dir / "est", std::map<int, int>{{4, 1}, {7, 1}}), Error);
  EXPECT_THROW(evaluate_object_dirs(dir / "missing", dir / "est", std::nullopt), Error);
  EXPECT_THROW(evaluate_object_dirs(dir / "est", dir / "est", std::nullopt), Error);  // no groundtruth-*.txt
  EXPECT_EQ(e.drift_world, "tracked point");
  EXPECT_NE(text.find("drift_world tracked point\n"), std::string::npos) << text;
}

// With both camera trajectories beside the objects', drift is measured in the cameras' alignment;
// an unreadable camera.txt is an error naming it.
TEST(ObjectsReport, DriftInTheCamerasWorld) {
  const auto dir = test::fresh_temp_dir();
  fs::create_directories(dir / "gt");
  fs::create_directories(dir / "est");
  const Trajectory object = object_trajectory(0.4, 3.0), camera = object_trajectory(2.2, 3.0);
  Pose A = Pose::Identity();  // estimate world -> ground-truth world
  A.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  A.translation() = Eigen::Vector3d(0.3, -0.2, 0.5);
  Trajectory est_camera = camera, est_object = as_model(object);
  for (auto& p : est_camera) p.T_world_x = A.inverse() * p.T_world_x;
  for (std::size_t i = 0; i < est_object.size(); ++i) est_object[i].T_world_x = A.inverse() * object[i].T_world_x * object[0].T_world_x.inverse();
  write_tum_trajectory(dir / "gt" / "groundtruth-1.txt", object);
  write_tum_trajectory(dir / "gt" / "groundtruth.txt", camera);
  write_tum_trajectory(dir / "est" / "model-1.txt", est_object);
  write_tum_trajectory(dir / "est" / "camera.txt", est_camera);
  const ObjectsEvaluation e = evaluate_object_dirs(dir / "gt", dir / "est", std::nullopt);
  EXPECT_EQ(e.drift_world, "cameras");
  ASSERT_EQ(e.pairs.size(), 1u);
  EXPECT_TRUE(e.pairs[0].errors.drift_in_given_world);
  EXPECT_LT(e.pairs[0].errors.drift_translation_m.max, 1e-5);
  EXPECT_LT(e.pairs[0].errors.drift_rotation_deg.max, 1e-3);
  EXPECT_EQ(to_json(e)["drift_world"], "cameras");
  // The same cameras give the drift relative to the camera: none here (the model's pose in the
  // camera is exact), a fourth number per sample in the JSON series and a field in the text.
  EXPECT_EQ(e.pairs[0].errors.camera_relative_drift_m.count, e.pairs[0].errors.drift_translation_m.count);
  EXPECT_LT(e.pairs[0].errors.camera_relative_drift_m.max, 1e-6);
  EXPECT_EQ(to_json(e)["objects"][0]["drift_series"][1].size(), 4u);
  EXPECT_NE(to_text(e).find(" camera_relative_drift_max_m 0.000000\n"), std::string::npos) << to_text(e);

  std::ofstream(dir / "est" / "camera.txt") << "1.0 not a pose\n";
  const std::string msg = test::error_of([&] { evaluate_object_dirs(dir / "gt", dir / "est", std::nullopt); });
  EXPECT_NE(msg.find((dir / "est" / "camera.txt").string()), std::string::npos) << msg;
}

// The drift series behind `eval objects --plot`: one sample per matched stamp, zero at the first,
// its maximum the summary's; the chart draws it (translation in blue) into a PNG per model.
TEST(ObjectsReport, DriftSeriesAndItsPlot) {
  const auto dir = test::fresh_temp_dir();
  fs::create_directories(dir / "gt");
  fs::create_directories(dir / "est");
  const Trajectory object = object_trajectory(0.4, 3.0);
  Trajectory est_object = as_model(object);
  // The model slips 2 cm along x halfway through and stays behind.
  for (std::size_t i = 0; i < est_object.size(); ++i) {
    est_object[i].T_world_x = object[i].T_world_x * object[0].T_world_x.inverse();
    if (i >= est_object.size() / 2) est_object[i].T_world_x.translation() += Eigen::Vector3d(0.02, 0, 0);
  }
  write_tum_trajectory(dir / "gt" / "groundtruth-1.txt", object);
  write_tum_trajectory(dir / "est" / "model-3.txt", est_object);
  const ObjectsEvaluation e = evaluate_object_dirs(dir / "gt", dir / "est", std::nullopt);
  ASSERT_EQ(e.pairs.size(), 1u);
  const auto& errors = e.pairs[0].errors;
  ASSERT_EQ(errors.drift_series.size(), errors.drift_translation_m.count + 1);
  EXPECT_EQ(errors.drift_series.front().translation_m, 0.0);
  double max_m = 0;
  for (const auto& s : errors.drift_series) max_m = std::max(max_m, s.translation_m);
  EXPECT_DOUBLE_EQ(max_m, errors.drift_translation_m.max);
  EXPECT_GT(max_m, 0.005);  // the slip shows (the tracked-point fit halves it)
  const nlohmann::json series = to_json(e)["objects"][0]["drift_series"];  // `eval objects --json`
  ASSERT_EQ(series.size(), errors.drift_series.size());
  EXPECT_EQ(series.back().size(), 3u) << "no cameras, no drift relative to the camera";
  EXPECT_DOUBLE_EQ(series.back()[0].get<double>(), errors.drift_series.back().timestamp_s);
  EXPECT_DOUBLE_EQ(series.back()[1].get<double>(), errors.drift_series.back().translation_m);

  write_drift_plots(e, dir / "plots");
  const cv::Mat png = cv::imread((dir / "plots" / "drift-model-3.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(png.empty());
  EXPECT_EQ(png.cols, DriftPlotParams{}.width_px);
  EXPECT_EQ(png.rows, DriftPlotParams{}.height_px);
  int blue = 0;
  for (int y = 0; y < png.rows; ++y)
    for (int x = 0; x < png.cols; ++x) {
      const cv::Vec3b c = png.at<cv::Vec3b>(y, x);
      blue += c[0] > 150 && c[1] < 120 && c[2] < 60;
    }
  EXPECT_GT(blue, 200) << "the translation curve is drawn";
}

TEST(ReconstructionReport, PlyAgainstGlbWithTransform) {
  const auto dir = test::fresh_temp_dir();
  // Ground truth: the unit square in z = 0 (two triangles).
  tinygltf::Model model;
  const float positions[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  tinygltf::Buffer buffer;
  buffer.data.resize(sizeof positions);
  std::memcpy(buffer.data.data(), positions, sizeof positions);
  model.buffers.push_back(buffer);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteLength = sizeof positions;
  model.bufferViews.push_back(view);
  tinygltf::Accessor acc;
  acc.bufferView = 0;
  acc.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  acc.count = 4;
  acc.type = TINYGLTF_TYPE_VEC3;
  acc.minValues = {0, 0, 0};
  acc.maxValues = {1, 1, 0};
  model.accessors.push_back(acc);
  tinygltf::Primitive fan;
  fan.attributes["POSITION"] = 0;
  fan.mode = TINYGLTF_MODE_TRIANGLE_FAN;
  tinygltf::Mesh mesh;
  mesh.primitives.push_back(fan);
  model.meshes.push_back(mesh);
  tinygltf::Node node;
  node.mesh = 0;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.asset.version = "2.0";
  tinygltf::TinyGLTF writer;
  ASSERT_TRUE(writer.WriteGltfSceneToFile(&model, (dir / "gt.glb").string(), true, true, false, true));
  // Model points 2 m up, at heights 0, 0.02 and 0.1 above the square once moved down.
  {
    std::ofstream f(dir / "model.ply");
    f << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
         "0.5 0.5 2.0\n0.25 0.75 2.02\n0.9 0.1 2.1\n";
  }
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(0, 0, -2);
  const auto e = evaluate_reconstruction_files(dir / "model.ply", dir / "gt.glb", T);
  EXPECT_EQ(e.points, 3u);
  EXPECT_EQ(e.triangles, 2u);
  EXPECT_NEAR(e.errors.distance_m.mean, 0.04, 1e-6);
  EXPECT_NEAR(e.errors.share_above[0], 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(e.errors.share_above[1], 1.0 / 3.0, 1e-12);
  const std::string text = to_text(e);
  EXPECT_NE(text.find("recon_mean_m 0.040000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("recon_share_above_0.01_m 0.666667\n"), std::string::npos) << text;
  EXPECT_EQ(to_json(e)["points"].get<int>(), 3);
  EXPECT_THROW(evaluate_reconstruction_files(dir / "absent.ply", dir / "gt.glb"), Error);
  EXPECT_THROW(evaluate_reconstruction_files(dir / "model.ply", dir / "absent.glb"), Error);
}

}  // namespace
}  // namespace cofusion::eval
