#include "synthetic/renderer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include "common/error.h"

namespace cofusion::synthetic {
namespace {

// One primitive prepared for one frame: everything the per-pixel loop needs, in float, in the
// primitive's frame. The ray direction of pixel (u, v) is d = d0 + u du + v dv (camera-z = 1, so the
// hit parameter t is the camera-frame depth).
struct FramePrimitive {
  const Primitive* primitive = nullptr;
  ShapeF shape;
  Eigen::Vector3f origin, d0, du, dv;
  Eigen::Vector3f to_light;  // unit vector towards the light, primitive frame
  Eigen::Matrix3f R_owner_primitive;  // to the owner's frame (world for the background, the object's
  Eigen::Vector3f t_owner_primitive;  // frame for an object's part), for RenderedFrame::points_object
  int u0 = 0, u1 = -1, v0 = 0, v1 = -1;  // conservative pixel rectangle it can cover
};

FramePrimitive prepare(const Primitive& p, const Pose& T_world_primitive, const Pose& T_owner_primitive,
                       const Pose& T_world_camera, const Intrinsics& K, const Eigen::Vector3d& to_light_world) {
  FramePrimitive f;
  f.primitive = &p;
  f.shape = shape_f(p);
  const Pose T_primitive_camera = T_world_primitive.inverse() * T_world_camera;
  const Eigen::Matrix3d R = T_primitive_camera.linear();
  f.origin = T_primitive_camera.translation().cast<float>();
  f.d0 = (R * Eigen::Vector3d(-K.cx / K.fx, -K.cy / K.fy, 1.0)).cast<float>();
  f.du = (R.col(0) / K.fx).cast<float>();
  f.dv = (R.col(1) / K.fy).cast<float>();
  f.to_light = (T_world_primitive.linear().transpose() * to_light_world).cast<float>();
  f.R_owner_primitive = T_owner_primitive.linear().cast<float>();
  f.t_owner_primitive = T_owner_primitive.translation().cast<float>();

  // Screen rectangle: project the corners of the shape's bounding box; a corner behind (or nearly
  // at) the camera plane makes it cover the whole image. Rooms always do.
  f.u0 = 0;
  f.v0 = 0;
  f.u1 = K.width - 1;
  f.v1 = K.height - 1;
  if (p.kind == PrimitiveKind::kRoom) return f;
  Eigen::Vector3d half = p.half_extents_m;  // box
  if (p.kind == PrimitiveKind::kSphere) half = Eigen::Vector3d::Constant(p.radius_m);
  if (p.kind == PrimitiveKind::kCylinder) half = Eigen::Vector3d(p.radius_m, p.radius_m, p.half_height_m);
  const Pose T_camera_primitive = T_primitive_camera.inverse();
  double umin = std::numeric_limits<double>::infinity(), umax = -umin, vmin = umin, vmax = -umin;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d corner((c & 1 ? 1 : -1) * half.x(), (c & 2 ? 1 : -1) * half.y(), (c & 4 ? 1 : -1) * half.z());
    const Eigen::Vector3d q = T_camera_primitive * corner;
    if (q.z() < 1e-3) return f;
    const double u = K.fx * q.x() / q.z() + K.cx, v = K.fy * q.y() / q.z() + K.cy;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
  }
  auto clamp_to = [](double x, int hi) { return static_cast<int>(std::clamp(x, -1.0, static_cast<double>(hi))); };
  f.u0 = clamp_to(std::floor(umin) - 1, K.width);
  f.u1 = clamp_to(std::ceil(umax) + 1, K.width - 1);
  f.v0 = clamp_to(std::floor(vmin) - 1, K.height);
  f.v1 = clamp_to(std::ceil(vmax) + 1, K.height - 1);
  return f;
}

// Nearest-pixel lateral shift: P(k) = Phi((k + 1/2) / sigma) - Phi((k - 1/2) / sigma), |k| <= 3,
// stored as a cumulative table so one uniform number picks the shift.
struct LateralTable {
  static constexpr int kMax = 3;
  std::array<float, 2 * kMax + 1> cumulative{};
  explicit LateralTable(double sigma_px) {
    auto phi = [&](double x) { return 0.5 * std::erfc(-x / (sigma_px * std::numbers::sqrt2)); };
    double total = 0;
    std::array<double, 2 * kMax + 1> p{};
    for (int k = -kMax; k <= kMax; ++k) {
      p[k + kMax] = sigma_px > 0 ? phi(k + 0.5) - phi(k - 0.5) : (k == 0 ? 1.0 : 0.0);
      total += p[k + kMax];
    }
    double acc = 0;
    for (int i = 0; i < 2 * kMax + 1; ++i) {
      acc += p[i] / total;
      cumulative[i] = static_cast<float>(acc);
    }
    cumulative.back() = 2.0f;  // catch rounding: every uniform in [0, 1) falls somewhere
  }
  int shift(float uniform) const {  // branch-free: the shifts are unpredictable by design
    int i = 0;
    for (int k = 0; k < 2 * kMax; ++k) i += uniform >= cumulative[k];
    return i - kMax;
  }
};

// Standard normal numbers by table lookup: kNormalBits-bit equiprobable levels (the normal
// quantiles at the bin centres, so the tails stop at +-3.5 sigma), rescaled to unit variance.
// Identical on every platform once built, and much cheaper per pixel than Box-Muller.
constexpr int kNormalBits = 12;

std::vector<float> make_normal_table() {
  const int n = 1 << kNormalBits;
  std::vector<double> q(n);
  double sum_sq = 0;
  for (int i = 0; i < n; ++i) {
    const double target = (i + 0.5) / n;  // quantile by bisection on the normal CDF
    double lo = -8, hi = 8;
    for (int it = 0; it < 48; ++it) {
      const double mid = 0.5 * (lo + hi);
      (0.5 * std::erfc(-mid / std::numbers::sqrt2) < target ? lo : hi) = mid;
    }
    q[i] = 0.5 * (lo + hi);
    sum_sq += q[i] * q[i];
  }
  const double scale = 1.0 / std::sqrt(sum_sq / n);
  std::vector<float> out(n);
  for (int i = 0; i < n; ++i) out[i] = static_cast<float>(q[i] * scale);
  return out;
}

// acos on [0, 1] to about 7e-5 rad (Abramowitz & Stegun 4.4.45): plenty for a noise sigma, and
// several times cheaper than acosf in the per-pixel loop.
inline float fast_acos01(float x) {
  return std::sqrt(1.0f - x) * (1.5707288f + x * (-0.2121144f + x * (0.0742610f - 0.0187293f * x)));
}

bool depth_noise_off(const KinectNoiseParams& n) {
  return !n.axial && n.lateral_sigma_px <= 0 && n.disparity_subpixel <= 0 && n.max_incidence_deg >= 90 &&
         n.edge_drop_probability <= 0 && n.min_depth_m <= 0 && n.max_depth_m <= 0;
}

// Zero-mean, unit-variance triangular number from 20 random bits (sum of two 10-bit uniforms).
inline float triangular(uint32_t bits) {
  constexpr float kInv = 1.0f / 1024.0f;
  const float a = static_cast<float>(bits & 1023u) * kInv, b = static_cast<float>((bits >> 10) & 1023u) * kInv;
  return (a + b - 1.0f + kInv) * 2.449489743f;  // variance of a + b is 1/6
}

enum Stream : uint64_t { kLateralStream = 0, kAxialStream = 1, kColorStream = 2 };

inline uint64_t frame_key(unsigned seed, int frame, Stream stream) {
  return mix64(mix64(seed) ^ (static_cast<uint64_t>(frame) * 0xD1B54A32D192ED03ull + stream));
}
inline uint64_t pixel_bits(uint64_t key, uint64_t index) { return mix64(key + index); }

}  // namespace

Renderer::Renderer(const SceneDescription& scene)
    : intrinsics_(scene.camera.intrinsics), light_(scene.light), background_(background_primitives(scene)),
      normal_table_(make_normal_table()) {
  for (size_t k = 0; k < scene.objects.size(); ++k) {
    std::vector<Primitive> parts;
    for (const PartDesc& part : scene.objects[k].parts)
      parts.push_back(make_primitive(part.shape, part.texture, static_cast<int>(k + 1)));
    object_parts_.push_back(std::move(parts));
  }
}

namespace {

// Every primitive visible in this frame (background, and the parts of the objects that are in the
// scene now, each at its object's pose and its own pose relative to the object), prepared.
std::vector<FramePrimitive> frame_primitives(const std::vector<Primitive>& background,
                                             const std::vector<std::vector<Primitive>>& object_parts,
                                             const RenderRequest& req, const Intrinsics& K,
                                             const Eigen::Vector3d& to_light_world) {
  std::vector<FramePrimitive> prims;
  prims.reserve(background.size() + object_parts.size());
  for (const Primitive& p : background)
    prims.push_back(prepare(p, p.T_world_primitive, p.T_world_primitive, req.T_world_camera, K, to_light_world));
  for (size_t k = 0; k < object_parts.size(); ++k) {
    if (!req.T_world_objects[k]) continue;
    const std::vector<Primitive>& parts = object_parts[k];
    const std::vector<Pose>* T_object_parts = req.T_object_parts.empty() ? nullptr : &req.T_object_parts[k];
    if (T_object_parts && !T_object_parts->empty() && T_object_parts->size() != parts.size())
      throw Error("synthetic render: " + std::to_string(T_object_parts->size()) + " part poses for object " +
                  std::to_string(k + 1) + ", which has " + std::to_string(parts.size()) + " parts");
    for (size_t i = 0; i < parts.size(); ++i) {
      const Pose T_object_part = T_object_parts && !T_object_parts->empty() ? (*T_object_parts)[i] : Pose::Identity();
      prims.push_back(prepare(parts[i], *req.T_world_objects[k] * T_object_part, T_object_part, req.T_world_camera, K,
                              to_light_world));
    }
  }
  return prims;
}

// The nearest primitive pixel (u, v)'s ray meets, and the hit's depth (null: none).
const FramePrimitive* cast_ray(const std::vector<const FramePrimitive*>& active, int u, float vf, float& t_best) {
  const float uf = static_cast<float>(u);
  t_best = std::numeric_limits<float>::infinity();
  const FramePrimitive* best = nullptr;
  for (const FramePrimitive* f : active) {
    if (u < f->u0 || u > f->u1) continue;
    const Eigen::Vector3f d = f->d0 + uf * f->du + vf * f->dv;
    float t;
    if (intersect(f->shape, f->origin, d, 1e-4f, t_best, t)) {
      t_best = t;
      best = f;
    }
  }
  return best;
}

// Noise-free rendering: colour (textured, Lambert-shaded, with the sensor's colour noise), true
// depth, instance ids, the cosine of incidence and, when asked, the surface points.
class RayCaster {
 public:
  RayCaster(const RenderRequest& req, const Intrinsics& K, float ambient, RenderedFrame& out)
      : req_(req), K_(K), ambient_(ambient), out_(out), color_sigma_(static_cast<float>(req.noise.color_sigma)),
        color_key_(frame_key(req.seed, req.frame_index, kColorStream)),
        R_world_camera_(req.T_world_camera.linear().cast<float>()),
        t_world_camera_(req.T_world_camera.translation().cast<float>()) {
    const int W = K.width, H = K.height;
    out.rgb.create(H, W, CV_8UC3);
    out.depth_true_m.create(H, W, CV_32FC1);
    out.instance_ids.create(H, W, CV_16UC1);
    out.cos_incidence.create(H, W, CV_32FC1);
    if (req.surface_points) {
      out.points_world.create(H, W, CV_32FC3);
      out.points_object.create(H, W, CV_32FC3);
    }
  }

  void render(const std::vector<FramePrimitive>& prims) {
    tbb::parallel_for(tbb::blocked_range<int>(0, K_.height, 4), [&](const tbb::blocked_range<int>& rows) {
      std::vector<const FramePrimitive*> active;
      active.reserve(prims.size());
      for (int v = rows.begin(); v < rows.end(); ++v) {
        active.clear();
        for (const FramePrimitive& f : prims)
          if (v >= f.v0 && v <= f.v1 && f.u0 <= f.u1) active.push_back(&f);
        for (int u = 0; u < K_.width; ++u) {
          float t = 0;
          const FramePrimitive* hit = cast_ray(active, u, static_cast<float>(v), t);
          if (hit) shade(*hit, u, v, t);
          else empty(u, v);
        }
      }
    });
  }

 private:
  void empty(int u, int v) {
    out_.rgb.ptr<cv::Vec3b>(v)[u] = cv::Vec3b(0, 0, 0);
    out_.depth_true_m.ptr<float>(v)[u] = 0;
    out_.instance_ids.ptr<uint16_t>(v)[u] = 0;
    out_.cos_incidence.ptr<float>(v)[u] = 0;
    if (req_.surface_points) {
      out_.points_world.ptr<cv::Vec3f>(v)[u] = cv::Vec3f(0, 0, 0);
      out_.points_object.ptr<cv::Vec3f>(v)[u] = cv::Vec3f(0, 0, 0);
    }
  }

  void shade(const FramePrimitive& hit, int u, int v, float t) {
    const float uf = static_cast<float>(u), vf = static_cast<float>(v);
    const Eigen::Vector3f d = hit.d0 + uf * hit.du + vf * hit.dv;
    const Eigen::Vector3f p = hit.origin + t * d;
    Eigen::Vector3f n = Eigen::Vector3f::UnitZ();
    int flat_axis = -1;
    surface_at(hit.shape, p, n, flat_axis);
    const float shading = ambient_ + (1.0f - ambient_) * std::max(0.0f, n.dot(hit.to_light));
    Eigen::Vector3f c = texture_color(texture_of(*hit.primitive, p, flat_axis), p, flat_axis) * shading;
    if (color_sigma_ > 0) {
      const uint64_t bits = pixel_bits(color_key_, static_cast<uint64_t>(v) * K_.width + u);
      c += color_sigma_ * Eigen::Vector3f(triangular(static_cast<uint32_t>(bits)), triangular(static_cast<uint32_t>(bits >> 20)),
                                          triangular(static_cast<uint32_t>(bits >> 40)));
    }
    cv::Vec3b& rgb = out_.rgb.ptr<cv::Vec3b>(v)[u];
    for (int ch = 0; ch < 3; ++ch) rgb[ch] = static_cast<uint8_t>(std::clamp(c[ch], 0.0f, 255.0f) + 0.5f);
    out_.depth_true_m.ptr<float>(v)[u] = t;
    out_.instance_ids.ptr<uint16_t>(v)[u] = static_cast<uint16_t>(hit.primitive->instance_id);
    out_.cos_incidence.ptr<float>(v)[u] = std::abs(n.dot(d)) / d.norm();
    if (req_.surface_points) {
      const Eigen::Vector3f p_camera(t * (uf - float(K_.cx)) / float(K_.fx), t * (vf - float(K_.cy)) / float(K_.fy), t);
      const Eigen::Vector3f pw = R_world_camera_ * p_camera + t_world_camera_;
      out_.points_world.ptr<cv::Vec3f>(v)[u] = cv::Vec3f(pw.x(), pw.y(), pw.z());
      const Eigen::Vector3f po = hit.R_owner_primitive * p + hit.t_owner_primitive;
      out_.points_object.ptr<cv::Vec3f>(v)[u] = cv::Vec3f(po.x(), po.y(), po.z());
    }
  }

  const RenderRequest& req_;
  const Intrinsics& K_;
  const float ambient_;
  RenderedFrame& out_;
  const float color_sigma_;
  const uint64_t color_key_;
  const Eigen::Matrix3f R_world_camera_;
  const Eigen::Vector3f t_world_camera_;
};

// Sensor noise on depth (see noise.h for the model and its order of effects): a lateral shift,
// readings dropped beyond the incidence limit and near depth edges, axial noise, quantisation and
// the range limits.
class DepthNoise {
 public:
  DepthNoise(const RenderRequest& req, const Intrinsics& K, const std::vector<float>& normal_table)
      : noise_(req.noise), K_(K), normal_table_(normal_table), lateral_(noise_.lateral_sigma_px),
        lateral_key_(frame_key(req.seed, req.frame_index, kLateralStream)),
        axial_key_(frame_key(req.seed, req.frame_index, kAxialStream)),
        cos_max_(noise_.max_incidence_deg >= 90 ? -1.0f
                                                : static_cast<float>(std::cos(noise_.max_incidence_deg * std::numbers::pi / 180))),
        edge_r_(static_cast<int>(std::floor(noise_.edge_radius_px))),
        edges_(noise_.edge_drop_probability > 0 && edge_r_ > 0),
        min_z_(static_cast<float>(noise_.min_depth_m)),
        max_z_(noise_.max_depth_m > 0 ? static_cast<float>(noise_.max_depth_m) : std::numeric_limits<float>::infinity()) {}

  void apply(RenderedFrame& out) const {
    out.depth_m.create(K_.height, K_.width, CV_32FC1);
    tbb::parallel_for(tbb::blocked_range<int>(0, K_.height, 4), [&](const tbb::blocked_range<int>& rows) {
      for (int v = rows.begin(); v < rows.end(); ++v) {
        float* noisy = out.depth_m.ptr<float>(v);
        for (int u = 0; u < K_.width; ++u) noisy[u] = noisy_depth(out, u, v);
      }
    });
  }

 private:
  float noisy_depth(const RenderedFrame& out, int u, int v) const {
    const int W = K_.width, H = K_.height;
    const uint64_t index = static_cast<uint64_t>(v) * W + u;
    const uint64_t lbits = pixel_bits(lateral_key_, index);
    int su = u, sv = v;
    if (noise_.lateral_sigma_px > 0) {
      // Bits 0-15 and 16-31 pick the shifts, 32-63 the edge drop: no bit is used twice.
      su = std::clamp(u + lateral_.shift(unit_float(static_cast<uint32_t>(lbits & 0xFFFFu) << 16)), 0, W - 1);
      sv = std::clamp(v + lateral_.shift(unit_float(static_cast<uint32_t>((lbits >> 16) & 0xFFFFu) << 16)), 0, H - 1);
    }
    float z = out.depth_true_m.ptr<float>(sv)[su];
    const float cos_ray = out.cos_incidence.ptr<float>(sv)[su];
    if (z <= 0 || cos_ray < cos_max_) return 0;
    if (edges_ && unit_float(static_cast<uint32_t>(lbits >> 32)) < float(noise_.edge_drop_probability) &&
        near_depth_edge(out.depth_true_m, su, sv, z))
      return 0;
    if (noise_.axial) {
      // Capped below 90 degrees, where the model's sigma diverges (only reachable with the
      // incidence cut-off disabled).
      const float theta = std::min(fast_acos01(std::min(1.0f, cos_ray)), 1.55f);
      z += noise_.axial_sigma_m(z, theta) * normal_table_[pixel_bits(axial_key_, index) >> (64 - kNormalBits)];
    }
    z = noise_.quantize(z, static_cast<float>(K_.fx));
    return (z >= min_z_ && z <= max_z_ && z > 0) ? z : 0.0f;
  }

  // Whether a depth within edge_radius_px of (su, sv) differs from z by more than edge_jump_ratio.
  bool near_depth_edge(const cv::Mat& depth_true_m, int su, int sv, float z) const {
    const float ratio = static_cast<float>(noise_.edge_jump_ratio);
    for (int dv = -edge_r_; dv <= edge_r_; ++dv) {
      const int nv = sv + dv;
      if (nv < 0 || nv >= K_.height) continue;
      const float* row = depth_true_m.ptr<float>(nv);
      for (int du = -edge_r_; du <= edge_r_; ++du) {
        const int nu = su + du;
        if (nu >= 0 && nu < K_.width && std::abs(row[nu] - z) > ratio * z) return true;
      }
    }
    return false;
  }

  const KinectNoiseParams& noise_;
  const Intrinsics& K_;
  const std::vector<float>& normal_table_;
  const LateralTable lateral_;
  const uint64_t lateral_key_, axial_key_;
  const float cos_max_;
  const int edge_r_;
  const bool edges_;
  const float min_z_, max_z_;
};

}  // namespace

RenderedFrame Renderer::render(const RenderRequest& req) const {
  if (req.T_world_objects.size() != object_parts_.size())
    throw Error("synthetic render: " + std::to_string(req.T_world_objects.size()) + " object poses for " +
                std::to_string(object_parts_.size()) + " objects");
  if (!req.T_object_parts.empty() && req.T_object_parts.size() != object_parts_.size())
    throw Error("synthetic render: part poses for " + std::to_string(req.T_object_parts.size()) + " objects, not " +
                std::to_string(object_parts_.size()));
  if (req.covered) return render_covered(req);
  const Eigen::Vector3d to_light_world = -light_.direction_world.normalized();
  const std::vector<FramePrimitive> prims = frame_primitives(background_, object_parts_, req, intrinsics_, to_light_world);
  RenderedFrame out;
  RayCaster(req, intrinsics_, static_cast<float>(light_.ambient), out).render(prims);
  if (depth_noise_off(req.noise)) {
    out.depth_m = out.depth_true_m.clone();
    return out;
  }
  DepthNoise(req, intrinsics_, normal_table_).apply(out);
  return out;
}

RenderedFrame Renderer::render_covered(const RenderRequest& req) const {
  // A hand over the lens: the depth camera sees nothing in range, the colour camera a little light
  // through the fingers, under twice the sensor's colour noise (the camera's gain is up in the dark).
  const int W = intrinsics_.width, H = intrinsics_.height;
  RenderedFrame out;
  out.depth_m = cv::Mat::zeros(H, W, CV_32FC1);
  out.depth_true_m = cv::Mat::zeros(H, W, CV_32FC1);
  out.instance_ids = cv::Mat::zeros(H, W, CV_16UC1);
  out.cos_incidence = cv::Mat::zeros(H, W, CV_32FC1);
  if (req.surface_points) {
    out.points_world = cv::Mat::zeros(H, W, CV_32FC3);
    out.points_object = cv::Mat::zeros(H, W, CV_32FC3);
  }
  out.rgb.create(H, W, CV_8UC3);
  const Eigen::Vector3f base(12, 7, 6);  // dark, faintly reddish
  const float sigma = 2.0f * static_cast<float>(req.noise.color_sigma);
  const uint64_t color_key = frame_key(req.seed, req.frame_index, kColorStream);
  for (int v = 0; v < H; ++v) {
    auto* rgb = out.rgb.ptr<cv::Vec3b>(v);
    for (int u = 0; u < W; ++u) {
      const uint64_t bits = pixel_bits(color_key, static_cast<uint64_t>(v) * W + u);
      const Eigen::Vector3f c = base + sigma * Eigen::Vector3f(triangular(static_cast<uint32_t>(bits)),
                                                               triangular(static_cast<uint32_t>(bits >> 20)),
                                                               triangular(static_cast<uint32_t>(bits >> 40)));
      for (int ch = 0; ch < 3; ++ch) rgb[u][ch] = static_cast<uint8_t>(std::clamp(c[ch], 0.0f, 255.0f) + 0.5f);
    }
  }
  return out;
}

}  // namespace cofusion::synthetic
