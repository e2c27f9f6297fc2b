// Rendering and ground truth: determinism, exact geometry of noiseless depth (every visible point
// lies on the surface of the object its mask names, in that object's ground-truth frame), masks
// checked against an independent sphere tracer, and the noise model's statistics.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "common/error.h"
#include "synthetic/synthetic_source.h"

namespace cofusion::synthetic {
namespace {

Eigen::Vector3d back_project(const Intrinsics& K, int u, int v, double z) {
  return Eigen::Vector3d((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z);
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  cv::Mat diff;
  cv::compare(a.reshape(1), b.reshape(1), diff, cv::CMP_NE);
  return cv::countNonZero(diff) == 0;
}

// Largest distance (metres) between a back-projected noiseless depth pixel and the surface of the
// object its instance id names, in that object's ground-truth frame (world for the background),
// with an articulated object's parts posed as at that frame.
struct GeometryCheck {
  double max_error_m = 0;
  int checked = 0;
  int missing_depth = 0;
};

GeometryCheck check_geometry(const SyntheticSequence& seq, int frame, int step) {
  const RenderedFrame r = seq.render(frame);
  const Intrinsics& K = seq.intrinsics();
  const Pose T_world_camera = seq.T_world_camera(frame);
  std::vector<std::optional<Pose>> T_object_world(seq.object_count() + 1);
  for (int id = 1; id <= seq.object_count(); ++id)
    if (auto T = seq.T_world_object(id, frame)) T_object_world[id] = T->inverse();
  GeometryCheck out;
  for (int v = 0; v < K.height; v += step)
    for (int u = 0; u < K.width; u += step) {
      const float z = r.depth_m.at<float>(v, u);
      if (z <= 0) {
        ++out.missing_depth;
        continue;
      }
      const int id = r.instance_ids.at<uint16_t>(v, u);
      const Eigen::Vector3d p_world = T_world_camera * back_project(K, u, v, z);
      EXPECT_TRUE(id == 0 || T_object_world[id].has_value()) << "pixel labelled with an absent object " << id;
      const Eigen::Vector3d p = id == 0 ? p_world : *T_object_world[id] * p_world;
      out.max_error_m = std::max(out.max_error_m, seq.distance_to_surface_m(id, p, frame));
      ++out.checked;
    }
  return out;
}

TEST(SyntheticRender, SameSeedSameFramesInAnyOrder) {
  const SceneDescription s = load_scene("one_object");
  SyntheticSequence a(s), b(s);
  const RenderedFrame b7 = b.render(7);  // b renders another frame first
  const RenderedFrame a5 = a.render(5), b5 = b.render(5);
  EXPECT_TRUE(identical(a5.rgb, b5.rgb));
  EXPECT_TRUE(identical(a5.depth_m, b5.depth_m));
  EXPECT_TRUE(identical(a5.instance_ids, b5.instance_ids));
  EXPECT_FALSE(identical(a5.depth_m, b7.depth_m));
  const Frame f = a.frame(5);
  EXPECT_TRUE(identical(f.depth_m, a5.depth_m));
  EXPECT_TRUE(identical(f.mask, a5.instance_ids));
}

TEST(SyntheticRender, DifferentSeedDifferentNoiseSameTruth) {
  const SceneDescription s = load_scene("one_object");
  SyntheticSequence a(s, 1), b(s, 2);
  const RenderedFrame ra = a.render(20), rb = b.render(20);
  EXPECT_TRUE(identical(ra.depth_true_m, rb.depth_true_m));
  EXPECT_TRUE(identical(ra.instance_ids, rb.instance_ids));
  cv::Mat diff;
  cv::compare(ra.depth_m, rb.depth_m, diff, cv::CMP_NE);
  EXPECT_GT(cv::countNonZero(diff), ra.depth_m.total() / 4);
  cv::compare(ra.rgb.reshape(1), rb.rgb.reshape(1), diff, cv::CMP_NE);
  EXPECT_GT(cv::countNonZero(diff), ra.rgb.total() / 4);
}

TEST(SyntheticRender, NoiselessDepthLiesOnTheLabelledObjectsSurface) {
  for (const auto& name : builtin_scene_names()) {
    SCOPED_TRACE(name);
    SyntheticSequence seq(load_scene(name));
    seq.set_noise(KinectNoiseParams::none());
    for (int frame : {0, seq.size() / 3, 2 * seq.size() / 3, seq.size() - 1}) {
      SCOPED_TRACE("frame " + std::to_string(frame));
      if (seq.covered(frame)) continue;  // a covered lens sees nothing (tested in person_test.cpp)
      const GeometryCheck c = check_geometry(seq, frame, 2);
      EXPECT_EQ(c.missing_depth, 0);  // the camera is inside the room: every ray hits something
      EXPECT_GT(c.checked, 70000);
      EXPECT_LT(c.max_error_m, 1e-4);
    }
  }
}

TEST(SyntheticRender, SurfacePointsMatchDepthAndPoses) {
  SyntheticSequence seq(load_scene("handover"));
  seq.set_noise(KinectNoiseParams::none());
  const int frame = 60;
  const RenderedFrame r = seq.render(frame, true);
  const Pose T_world_camera = seq.T_world_camera(frame);
  double max_world = 0, max_object = 0;
  for (int v = 0; v < 480; v += 3)
    for (int u = 0; u < 640; u += 3) {
      const Eigen::Vector3d p_world = T_world_camera * back_project(seq.intrinsics(), u, v, r.depth_true_m.at<float>(v, u));
      const cv::Vec3f w = r.points_world.at<cv::Vec3f>(v, u), o = r.points_object.at<cv::Vec3f>(v, u);
      max_world = std::max(max_world, (p_world - Eigen::Vector3d(w[0], w[1], w[2])).norm());
      const int id = r.instance_ids.at<uint16_t>(v, u);
      const Eigen::Vector3d p_object = id == 0 ? p_world : seq.T_world_object(id, frame)->inverse() * p_world;
      max_object = std::max(max_object, (p_object - Eigen::Vector3d(o[0], o[1], o[2])).norm());
    }
  EXPECT_LT(max_world, 1e-4);
  EXPECT_LT(max_object, 1e-4);
}

// Independent check of masks and depth: sphere tracing on the primitives' signed distances (double
// precision, no ray-intersection code shared with the renderer).
TEST(SyntheticRender, MasksAgreeWithAnIndependentSphereTracer) {
  for (const char* name : {"one_object", "handover", "table_placement", "walking_people"}) {
    SCOPED_TRACE(name);
    SyntheticSequence seq(load_scene(name));
    seq.set_noise(KinectNoiseParams::none());
    const int frame = seq.size() / 2;
    const RenderedFrame r = seq.render(frame);
    const Pose T_world_camera = seq.T_world_camera(frame);
    struct Placed {
      const Primitive* p;
      Pose T_primitive_world;
    };
    std::vector<Placed> placed;
    for (const Primitive& p : seq.renderer().background()) placed.push_back({&p, p.T_world_primitive.inverse()});
    for (int id = 1; id <= seq.object_count(); ++id) {
      const auto T = seq.T_world_object(id, frame);
      if (!T) continue;
      const std::vector<Pose> T_object_parts = seq.T_object_parts(id, frame);
      const auto& parts = seq.renderer().object_parts()[id - 1];
      for (size_t i = 0; i < parts.size(); ++i) placed.push_back({&parts[i], (*T * T_object_parts[i]).inverse()});
    }
    int compared = 0, mismatched = 0, converged = 0;
    double max_depth_error = 0;
    const Intrinsics& K = seq.intrinsics();
    for (int v = 2; v < K.height; v += 6)
      for (int u = 2; u < K.width; u += 6) {
        const Eigen::Vector3d d_camera((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
        const Eigen::Vector3d o = T_world_camera.translation(), d = T_world_camera.linear() * d_camera;
        const double step_scale = 1.0 / d.norm();
        double t = 0;
        int hit = -1;
        for (int it = 0; it < 400 && t < 20; ++it) {
          const Eigen::Vector3d p = o + t * d;
          double best = std::numeric_limits<double>::infinity();
          int best_id = -1;
          for (const Placed& q : placed) {
            const double sd = q.p->signed_distance(q.T_primitive_world * p);
            if (sd < best) {
              best = sd;
              best_id = q.p->instance_id;
            }
          }
          if (best < 1e-7) {
            hit = best_id;
            break;
          }
          t += best * step_scale;
        }
        if (hit < 0) continue;  // grazing rays may not converge
        ++converged;
        ++compared;
        if (hit != r.instance_ids.at<uint16_t>(v, u)) {
          ++mismatched;
        } else {
          max_depth_error = std::max(max_depth_error, std::abs(t - r.depth_true_m.at<float>(v, u)));
        }
      }
    EXPECT_GT(converged, 7000);
    EXPECT_LE(mismatched, compared / 500) << mismatched << " of " << compared;  // silhouette pixels only
    EXPECT_LT(max_depth_error, 1e-3);
  }
}

double fraction_of(const cv::Mat& ids, int id) {
  cv::Mat m = ids == id;
  return static_cast<double>(cv::countNonZero(m)) / static_cast<double>(ids.total());
}

TEST(SyntheticRender, OneObjectMovesAndIsLargeEnough) {
  SyntheticSequence seq(load_scene("one_object"));
  ASSERT_EQ(seq.object_count(), 1);
  const Pose start = *seq.T_world_object(1, 0), end = *seq.T_world_object(1, 60);
  EXPECT_GT((start.translation() - end.translation()).norm(), 0.2);
  for (int f = 15; f < seq.size(); f += 10) {
    const Pose a = *seq.T_world_object(1, f), b = *seq.T_world_object(1, f + 1);
    const double speed = (a.translation() - b.translation()).norm();
    if (speed < 0.002) continue;  // at rest
    EXPECT_GT(fraction_of(seq.render(f).instance_ids, 1), 0.03) << "frame " << f;
  }
}

TEST(SyntheticRender, EveryShippedSceneRendersWithPlausibleMotion) {
  for (const auto& name : builtin_scene_names()) {
    SCOPED_TRACE(name);
    SyntheticSequence seq(load_scene(name));
    const RenderedFrame r = seq.render(seq.size() - 1);
    EXPECT_EQ(r.rgb.type(), CV_8UC3);
    EXPECT_EQ(r.depth_m.type(), CV_32FC1);
    EXPECT_EQ(r.instance_ids.type(), CV_16UC1);
    EXPECT_EQ(r.rgb.cols, 640);
    EXPECT_EQ(r.rgb.rows, 480);
    EXPECT_GT(cv::countNonZero(r.depth_m), 0.7 * r.depth_m.total());  // holes, but mostly readings
    double max_id = 0;
    cv::minMaxLoc(r.instance_ids, nullptr, &max_id);
    EXPECT_LE(max_id, seq.object_count());
    // Hand-held camera and carried objects: centimetres and a few degrees per frame at most (people
    // walk up to 1.4 m/s: under 5 cm). camera_loss's whip pan is meant to be fast (tested in
    // person_test.cpp).
    const bool whip_pan = name == "camera_loss";
    for (int f = 0; f + 1 < seq.size(); ++f) {
      const Pose dc = seq.T_world_camera(f).inverse() * seq.T_world_camera(f + 1);
      EXPECT_LT(dc.translation().norm(), 0.02) << "camera, frame " << f;
      if (!whip_pan) {
        EXPECT_LT(Eigen::AngleAxisd(dc.linear()).angle(), 2 * std::numbers::pi / 180) << "camera, frame " << f;
      }
      for (int id = 1; id <= seq.object_count(); ++id) {
        const auto a = seq.T_world_object(id, f), b = seq.T_world_object(id, f + 1);
        if (!a || !b) continue;
        EXPECT_LT((a->translation() - b->translation()).norm(), 0.05) << "object " << id << ", frame " << f;
        EXPECT_LT(Eigen::AngleAxisd(a->linear().transpose() * b->linear()).angle(), 6 * std::numbers::pi / 180)
            << "object " << id << ", frame " << f;
      }
    }
    // Every object is seen at some point, and then covers a sizeable part of the image.
    seq.set_noise(KinectNoiseParams::none());  // masks only: skip the noise
    std::vector<double> best(seq.object_count() + 1, 0.0);
    for (int f = 0; f < seq.size(); f += 20) {
      const cv::Mat ids = seq.render(f).instance_ids;
      for (int id = 1; id <= seq.object_count(); ++id) best[id] = std::max(best[id], fraction_of(ids, id));
    }
    for (int id = 1; id <= seq.object_count(); ++id) EXPECT_GT(best[id], 0.03) << "object " << id;
  }
}

// Axial noise and disparity quantisation alone: the error of every reading, divided by the model's
// standard deviation at that depth and angle (sigma_z^2 + step^2 / 12), has unit RMS.
TEST(SyntheticNoise, AxialErrorsMatchTheModel) {
  SyntheticSequence seq(load_scene("one_object"));
  KinectNoiseParams p = seq.scene().noise;
  p.lateral_sigma_px = 0;
  p.edge_drop_probability = 0;
  seq.set_noise(p);
  const RenderedFrame r = seq.render(10);
  double sum_sq = 0, sum = 0;
  int n = 0;
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const double z = r.depth_m.at<float>(v, u), z_true = r.depth_true_m.at<float>(v, u);
      if (z <= 0) continue;
      const double theta = std::acos(std::min(1.0, static_cast<double>(r.cos_incidence.at<float>(v, u))));
      const double sigma = p.axial_sigma_m(z_true, theta), step = p.quantization_step_m(z_true, seq.intrinsics().fx);
      const double e = (z - z_true) / std::sqrt(sigma * sigma + step * step / 12);
      sum += e;
      sum_sq += e * e;
      ++n;
    }
  ASSERT_GT(n, 200000);
  EXPECT_NEAR(std::sqrt(sum_sq / n), 1.0, 0.1);
  EXPECT_NEAR(sum / n, 0.0, 0.05);
}

TEST(SyntheticNoise, QuantisedToEighthPixelDisparity) {
  SyntheticSequence seq(load_scene("static_room"));
  KinectNoiseParams p = KinectNoiseParams::none();
  p.disparity_subpixel = 8;
  seq.set_noise(p);
  const RenderedFrame r = seq.render(0);
  const double fb = seq.intrinsics().fx * p.baseline_m;
  for (int v = 0; v < 480; v += 7)
    for (int u = 0; u < 640; u += 7) {
      const double z = r.depth_m.at<float>(v, u), z_true = r.depth_true_m.at<float>(v, u);
      const double steps = 8 * fb / z;
      ASSERT_NEAR(steps, std::round(steps), 1e-3 * steps);
      ASSERT_LE(std::abs(z - z_true), 0.5 * p.quantization_step_m(z_true, seq.intrinsics().fx) * 1.01 + 1e-6);
    }
}

TEST(SyntheticNoise, HolesAtGrazingAnglesEdgesAndOutOfRange) {
  SyntheticSequence seq(load_scene("static_room"));
  KinectNoiseParams p = KinectNoiseParams::none();
  p.max_incidence_deg = 75;
  p.min_depth_m = 0.4;
  p.max_depth_m = 3.0;  // the far walls are beyond this
  seq.set_noise(p);
  const RenderedFrame r = seq.render(0);
  const float cos_max = static_cast<float>(std::cos(75 * std::numbers::pi / 180));
  int grazing = 0, far = 0;
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const float z = r.depth_m.at<float>(v, u), z_true = r.depth_true_m.at<float>(v, u);
      const bool expect_hole = r.cos_incidence.at<float>(v, u) < cos_max || z_true > 3.0f || z_true < 0.4f;
      grazing += r.cos_incidence.at<float>(v, u) < cos_max;
      far += z_true > 3.0f;
      ASSERT_EQ(z == 0, expect_hole) << u << "," << v;
      if (!expect_hole) {
        ASSERT_EQ(z, z_true);
      }
    }
  EXPECT_GT(grazing, 100);
  EXPECT_GT(far, 1000);

  // Depth discontinuities: only pixels next to a jump are dropped, about half of them.
  p = KinectNoiseParams::none();
  p.edge_drop_probability = 0.5;
  seq.set_noise(p);
  const RenderedFrame e = seq.render(0);
  int edge_pixels = 0, dropped = 0;
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const float z = e.depth_true_m.at<float>(v, u);
      bool jump = false;
      for (int dv = -1; dv <= 1; ++dv)
        for (int du = -1; du <= 1; ++du) {
          const int nu = std::clamp(u + du, 0, 639), nv = std::clamp(v + dv, 0, 479);
          jump |= std::abs(e.depth_true_m.at<float>(nv, nu) - z) > p.edge_jump_ratio * z;
        }
      const bool hole = e.depth_m.at<float>(v, u) == 0;
      if (!jump) {
        ASSERT_FALSE(hole) << u << "," << v;
      }
      edge_pixels += jump;
      dropped += jump && hole;
    }
  ASSERT_GT(edge_pixels, 1000);
  EXPECT_NEAR(static_cast<double>(dropped) / edge_pixels, 0.5, 0.05);
}

// Full Kinect model: readings stay in range and their errors stay at the model's scale (the lateral
// shift adds error on slanted surfaces and at edges, hence the looser bound on a robust statistic).
TEST(SyntheticNoise, FullModelErrorsAreAtTheModelsScale) {
  SyntheticSequence seq(load_scene("one_object"));
  const KinectNoiseParams& p = seq.noise();
  const RenderedFrame r = seq.render(30);
  std::vector<double> ratios;
  int holes = 0;
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const double z = r.depth_m.at<float>(v, u), z_true = r.depth_true_m.at<float>(v, u);
      if (z == 0) {
        ++holes;
        continue;
      }
      ASSERT_GE(z, p.min_depth_m);
      ASSERT_LE(z, p.max_depth_m);
      const double theta = std::acos(std::min(1.0, static_cast<double>(r.cos_incidence.at<float>(v, u))));
      const double sigma = std::hypot(p.axial_sigma_m(z_true, theta), p.quantization_step_m(z_true, 525.0) / std::sqrt(12.0));
      ratios.push_back(std::abs(z - z_true) / sigma);
    }
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  const double median = ratios[ratios.size() / 2];
  EXPECT_GT(median, 0.4);  // a normal's median |x| is 0.674
  EXPECT_LT(median, 1.5);
  EXPECT_GT(holes, 500);                     // edges and grazing angles
  EXPECT_LT(holes, static_cast<int>(0.2 * r.depth_m.total()));
}

TEST(SyntheticSource, DeliversFramesWithGroundTruth) {
  auto source = make_synthetic_source("", 0, 2);
  ASSERT_TRUE(source->size().has_value());
  EXPECT_EQ(*source->size(), 2);
  EXPECT_NE(source->describe().find("static_room"), std::string::npos) << source->describe();
  EXPECT_DOUBLE_EQ(source->intrinsics().fx, 525);
  for (int i = 0; i < 2; ++i) {
    auto f = source->next();
    ASSERT_TRUE(f.has_value());
    EXPECT_EQ(f->index, i);
    EXPECT_DOUBLE_EQ(f->timestamp_s, i / 30.0);
    EXPECT_EQ(f->rgb.type(), CV_8UC3);
    EXPECT_EQ(f->depth_m.type(), CV_32FC1);
    EXPECT_EQ(f->mask.type(), CV_16UC1);
    EXPECT_EQ(f->intrinsics.width, 640);
    ASSERT_TRUE(f->T_world_camera_gt.has_value());
    cv::Mat finite = f->depth_m == f->depth_m;  // no NaN
    EXPECT_EQ(cv::countNonZero(finite), static_cast<int>(f->depth_m.total()));
  }
  EXPECT_FALSE(source->next().has_value());
  EXPECT_THROW(make_synthetic_source("no_such_scene", 0, {}), Error);
}

}  // namespace
}  // namespace cofusion::synthetic
