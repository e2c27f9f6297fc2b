// `cofusion generate`'s output: a TUM folder with per-object ground truth and glTF geometry,
// written all-or-nothing; exported meshes agree with the analytic geometry.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>

#include "common/error.h"
#include "io/image_io.h"
#include "io/trajectory.h"
#include "io/tum_source.h"
#include "support/test_support.h"
#include "synthetic/dataset_writer.h"
#include "synthetic/gltf_export.h"
#include "synthetic/synthetic_source.h"

namespace cofusion::synthetic {
namespace {
namespace fs = std::filesystem;

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> data_lines(const fs::path& p) {
  std::vector<std::string> out;
  std::istringstream in(read_text(p));
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') out.push_back(line);
  return out;
}

bool leftovers(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.find(".tmp-") != std::string::npos || n.find(".old-") != std::string::npos) return true;
  }
  return false;
}

// Distance from p to triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5).
double point_triangle_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return (p - a).norm();
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return (p - b).norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (p - (a + d1 / (d1 - d3) * ab)).norm();
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return (p - c).norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (p - (a + d2 / (d2 - d6) * ac)).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return (p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  const double denom = 1.0 / (va + vb + vc);
  return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}

double distance_to_mesh(const Mesh& m, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i + 2 < m.indices.size(); i += 3)
    best = std::min(best, point_triangle_distance(p, m.positions[m.indices[i]].cast<double>(),
                                                  m.positions[m.indices[i + 1]].cast<double>(),
                                                  m.positions[m.indices[i + 2]].cast<double>()));
  return best;
}

TEST(SyntheticDataset, WritesATumFolderWithGroundTruth) {
  const fs::path root = test::fresh_temp_dir();
  const fs::path out = root / "handover";
  SyntheticSequence seq(load_scene("handover"), 0, 3);
  int last_progress = 0;
  DatasetOptions options;
  options.progress = [&](int done, int total) {
    EXPECT_EQ(total, 3);
    EXPECT_EQ(done, last_progress + 1);
    last_progress = done;
  };
  write_tum_dataset(seq, out, options);
  EXPECT_EQ(last_progress, 3);
  EXPECT_FALSE(leftovers(root));

  const auto rgb = data_lines(out / "rgb.txt"), depth = data_lines(out / "depth.txt");
  const auto assoc = data_lines(out / "associations.txt");
  ASSERT_EQ(rgb.size(), 3u);
  ASSERT_EQ(depth.size(), 3u);
  ASSERT_EQ(assoc.size(), 3u);
  EXPECT_EQ(rgb[1], "0.033333 rgb/0.033333.png");
  EXPECT_EQ(assoc[2], "0.066667 rgb/0.066667.png 0.066667 depth/0.066667.png");

  for (int i = 0; i < 3; ++i) {
    const Frame f = seq.frame(i);
    const std::string name = rgb[i].substr(rgb[i].find(' ') + 5);  // after "rgb/"
    const cv::Mat colour = read_rgb_image(out / "rgb" / name);
    cv::Mat diff;
    cv::compare(colour.reshape(1), f.rgb.reshape(1), diff, cv::CMP_NE);
    EXPECT_EQ(cv::countNonZero(diff), 0);
    const cv::Mat depth_m = read_depth_image(out / "depth" / name, kTumDepthUnitsPerMetre);
    double max_err = 0;
    cv::minMaxLoc(cv::abs(depth_m - f.depth_m), nullptr, &max_err);
    EXPECT_LE(max_err, 0.5 / kTumDepthUnitsPerMetre + 1e-6);
    const cv::Mat mask = read_mask_image(out / "masks" / name);
    cv::compare(mask, f.mask, diff, cv::CMP_NE);
    EXPECT_EQ(cv::countNonZero(diff), 0);
  }

  const Trajectory cam = read_tum_trajectory(out / "groundtruth.txt");
  ASSERT_EQ(cam.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(cam[i].timestamp_s, i / 30.0, 1e-6);
    EXPECT_TRUE(cam[i].T_world_x.isApprox(seq.T_world_camera(i), 1e-5));
  }
  for (int id = 1; id <= 3; ++id) {
    const Trajectory obj = read_tum_trajectory(out / ("groundtruth-" + std::to_string(id) + ".txt"));
    ASSERT_EQ(obj.size(), id == 3 ? 0u : 3u) << id;  // arm B enters at frame 20
    for (size_t i = 0; i < obj.size(); ++i) EXPECT_TRUE(obj[i].T_world_x.isApprox(*seq.T_world_object(id, i), 1e-5));
    const Mesh m = read_glb(out / "geometry" / ("object-" + std::to_string(id) + ".glb"));
    EXPECT_EQ(m.positions.size(), 24u);  // boxes
    EXPECT_EQ(m.indices.size(), 36u);
  }
  const Mesh background = read_glb(out / "geometry" / "background.glb");
  EXPECT_EQ(background.indices.size(), 6u * 36u);  // room + table top + 4 legs
  EXPECT_EQ(read_text(out / "scene.json"), seq.scene().json_text);
  EXPECT_EQ(data_lines(out / "calibration.txt"), std::vector<std::string>{"525.000000 525.000000 319.500000 239.500000 640 480"});
  const auto objects = data_lines(out / "objects.txt");
  ASSERT_EQ(objects.size(), 3u);
  EXPECT_EQ(objects[0], "1 cube box 0 2");
  // Each object's "class" from the scene, by instance id, read back with the masks.
  EXPECT_EQ(data_lines(out / "masks" / "classes.txt"), (std::vector<std::string>{"1 box", "2 arm", "3 arm"}));
  TumSource back(out);
  const auto frame = back.next();
  ASSERT_TRUE(frame);
  ASSERT_TRUE(frame->mask_classes);
  EXPECT_EQ(frame->mask_classes->name_by_id, seq.mask_classes()->name_by_id);
}

TEST(SyntheticSequence, FramesCarryEachObjectsClass) {
  SyntheticSequence seq(load_scene("table_placement"), 0, 1);
  const std::map<std::uint16_t, std::string> expected{{1, "box"}, {2, "can"}, {3, "ball"}};
  ASSERT_TRUE(seq.mask_classes());
  EXPECT_EQ(seq.mask_classes()->name_by_id, expected);
  const Frame f = seq.frame(0);
  EXPECT_EQ(f.mask_classes.get(), seq.mask_classes().get());
  EXPECT_EQ(seq.objects()[1].class_name, "can");
}

TEST(SyntheticDataset, RefusesANonEmptyTargetUnlessOverwriting) {
  const fs::path root = test::fresh_temp_dir();
  const fs::path out = root / "data";
  fs::create_directories(out);
  std::ofstream(out / "keep.txt") << "precious";
  SyntheticSequence seq(load_scene("one_object"), 0, 1);
  try {
    write_tum_dataset(seq, out);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not empty"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::exists(out / "keep.txt"));
  EXPECT_FALSE(fs::exists(out / "rgb.txt"));

  DatasetOptions overwrite;
  overwrite.overwrite = true;
  write_tum_dataset(seq, out, overwrite);
  EXPECT_FALSE(fs::exists(out / "keep.txt"));
  EXPECT_TRUE(fs::exists(out / "rgb.txt"));
  EXPECT_FALSE(leftovers(root));
}

TEST(SyntheticDataset, FailureLeavesNothingBehind) {
  const fs::path root = test::fresh_temp_dir();
  std::ofstream(root / "a_file") << "x";
  SyntheticSequence seq(load_scene("one_object"), 0, 1);
  EXPECT_THROW(write_tum_dataset(seq, root / "a_file" / "out"), Error);  // parent is not a folder
  EXPECT_THROW(write_tum_dataset(seq, root / "a_file"), Error);          // target is a file
  SyntheticSequence empty(load_scene("one_object"), 0, 0);
  EXPECT_THROW(write_tum_dataset(empty, root / "out"), Error);  // nothing to write
  EXPECT_FALSE(fs::exists(root / "out"));
  EXPECT_FALSE(leftovers(root));
}

TEST(SyntheticGeometry, ExportedMeshesLieOnTheAnalyticSurfaces) {
  const fs::path dir = test::fresh_temp_dir();
  for (const auto& name : builtin_scene_names()) {
    SCOPED_TRACE(name);
    SyntheticSequence seq(load_scene(name));
    for (int id = 0; id <= seq.object_count(); ++id) {
      const fs::path file = dir / (name + "-" + std::to_string(id) + ".glb");
      seq.write_glb(id, file);
      const Mesh m = read_glb(file);
      ASSERT_FALSE(m.indices.empty());
      ASSERT_EQ(m.indices.size() % 3, 0u);
      for (size_t i = 0; i < m.positions.size(); ++i) {
        ASSERT_LT(seq.distance_to_surface_m(id, m.positions[i].cast<double>()), 1e-5) << "vertex " << i;
        ASSERT_NEAR(m.normals[i].norm(), 1.0f, 1e-5f);
        ASSERT_TRUE((m.colors[i].array() >= 0).all() && (m.colors[i].array() <= 1).all());
      }
      // Triangles wind counter-clockwise around the vertex normals (outward; inward for the room).
      for (size_t i = 0; i < m.indices.size(); i += 3) {
        const Eigen::Vector3f a = m.positions[m.indices[i]], b = m.positions[m.indices[i + 1]],
                              c = m.positions[m.indices[i + 2]];
        const Eigen::Vector3f n = m.normals[m.indices[i]] + m.normals[m.indices[i + 1]] + m.normals[m.indices[i + 2]];
        ASSERT_GT((b - a).cross(c - a).dot(n), 0.0f) << "triangle " << i / 3;
      }
    }
  }
}

// Ground truth through the exported files alone: noiseless depth back-projected with the
// ground-truth camera pose and moved into the object's frame with its ground-truth pose lies on the
// exported triangle mesh (boxes are exact meshes).
TEST(SyntheticGeometry, NoiselessDepthLiesOnTheExportedBoxMesh) {
  const fs::path dir = test::fresh_temp_dir();
  SyntheticSequence seq(load_scene("one_object"));
  seq.set_noise(KinectNoiseParams::none());
  seq.write_glb(1, dir / "object-1.glb");
  const Mesh mesh = read_glb(dir / "object-1.glb");
  const int frame = 60;
  const RenderedFrame r = seq.render(frame);
  const Pose T_object_camera = seq.T_world_object(1, frame)->inverse() * seq.T_world_camera(frame);
  const Intrinsics& K = seq.intrinsics();
  double max_error = 0;
  int checked = 0;
  for (int v = 0; v < K.height; v += 3)
    for (int u = 0; u < K.width; u += 3) {
      if (r.instance_ids.at<uint16_t>(v, u) != 1) continue;
      const double z = r.depth_m.at<float>(v, u);
      const Eigen::Vector3d p = T_object_camera * Eigen::Vector3d((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z);
      max_error = std::max(max_error, distance_to_mesh(mesh, p));
      ++checked;
    }
  EXPECT_GT(checked, 500);
  EXPECT_LT(max_error, 1e-4);
}

}  // namespace
}  // namespace cofusion::synthetic
