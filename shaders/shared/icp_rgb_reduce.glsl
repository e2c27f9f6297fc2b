// The body of icp_rgb_reduce.comp and icp_rgb_reduce_reweighted.comp (see the former); with
// ICP_RGB_REWEIGHTED defined, photometric residuals carry gradient-dependent weights
// (IcpRgbReduceParams::gradient_weight_c), with ICP_RGB_FLAG_CAUCHY Cauchy's robust weight instead
// of Huber's, and with ICP_RGB_FLAG_TILE_WEIGHTS their live tile's weight. Without it the code is
// exactly the plain kernel's, so results stay bit-identical where these options are off.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "shared/host_device.h"
#include "shared/depth_noise.h"
#include "shared/texel_access.glsl"
layout(local_size_x = ICP_RGB_GROUP_SIZE) in;
layout(binding = ICP_RGB_BINDING_LIVE_VERTEX) uniform usamplerBuffer live_vertex;  // texel view of vec4
layout(binding = ICP_RGB_BINDING_LIVE_NORMAL) uniform usamplerBuffer live_normal;  // texel view of vec4
layout(binding = ICP_RGB_BINDING_LIVE_INTENSITY) uniform usamplerBuffer live_intensity;  // texel view of float
layout(binding = ICP_RGB_BINDING_REF_VERTEX) uniform usamplerBuffer ref_vertex;  // texel view of vec4
layout(binding = ICP_RGB_BINDING_REF_NORMAL) uniform usamplerBuffer ref_normal;  // texel view of vec4
layout(binding = ICP_RGB_BINDING_REF_INTENSITY) uniform usamplerBuffer ref_intensity;  // texel view of float
layout(binding = ICP_RGB_BINDING_REF_GRADIENT) uniform usamplerBuffer ref_gradient;  // texel view of vec2
layout(std430, binding = ICP_RGB_BINDING_PARTIALS) writeonly buffer Partials { float partials[]; };
layout(binding = ICP_RGB_BINDING_LIVE_GRADIENT) uniform usamplerBuffer live_gradient;  // texel view of vec2
layout(binding = ICP_RGB_BINDING_LIVE_DEPTH) uniform usamplerBuffer live_depth;  // texel view of float
#ifdef ICP_RGB_REWEIGHTED
layout(std430, binding = ICP_RGB_BINDING_TILE_WEIGHTS) readonly buffer TileWeights { float tile_weights[]; };
#endif
layout(push_constant) uniform Push { IcpRgbReduceParams p; };

// 16 vec4 per subgroup: 8 for the ICP term (its 29 values, the valid and occluding live counts), 8 for the
// photometric term. 64 subgroups * 256 bytes = 16 KiB, Vulkan's guaranteed minimum.
shared vec4 subgroup_sums[ICP_RGB_MAX_SUBGROUPS * 16];

// One term's 29 sums packed in 8 vec4, in the order of shared/host_device.h. Named variables and
// no arrays: indexed arrays of accumulators end up in scratch memory on lavapipe (6x slower).
struct Term {
  vec4 s0, s1, s2, s3, s4, s5, s6, s7;
};

void accumulate(inout Term t, vec3 a, vec3 b, float r) {  // J = (a, b)
  t.s0 += a.x * vec4(a.x, a.y, a.z, b.x);                 // (0,0) (0,1) (0,2) (0,3)
  t.s1 += vec4(a.x * b.y, a.x * b.z, a.y * a.y, a.y * a.z);  // (0,4) (0,5) (1,1) (1,2)
  t.s2 += vec4(a.y * b.x, a.y * b.y, a.y * b.z, a.z * a.z);  // (1,3) (1,4) (1,5) (2,2)
  t.s3 += vec4(a.z * b.x, a.z * b.y, a.z * b.z, b.x * b.x);  // (2,3) (2,4) (2,5) (3,3)
  t.s4 += vec4(b.x * b.y, b.x * b.z, b.y * b.y, b.y * b.z);  // (3,4) (3,5) (4,4) (4,5)
  t.s5 += vec4(b.z * b.z, r * a.x, r * a.y, r * a.z);        // (5,5) J^T r
  t.s6 += vec4(r * b.x, r * b.y, r * b.z, r * r);            // J^T r, r^2
  t.s7.x += 1.0;                                             // count
}

// dI/dq for an intensity gradient g (intensity / 255 per pixel) at the projection of q:
// g * d pi(q) / dq, pi(q) = (fx qx/qz + cx, fy qy/qz + cy).
vec3 intensity_jacobian(vec2 g, vec3 q) {
  const float inv_z = 1.0 / q.z;
  return vec3(g.x * p.fx * inv_z, g.y * p.fy * inv_z, -(g.x * p.fx * q.x + g.y * p.fy * q.y) * inv_z * inv_z);
}
// Huber weight, applied as sqrt(w) to J and r: sums of w J^T J, w J^T r, w r^2.
float huber_sqrt_weight(float r, float delta) {
  return delta > 0.0 && abs(r) > delta ? sqrt(delta / abs(r)) : 1.0;
}
#ifdef ICP_RGB_REWEIGHTED
// sqrt of the gradient weight c^2 / (c^2 + |g|^2) (IcpRgbReduceParams::gradient_weight_c; 1 for c 0).
float gradient_sqrt_weight(vec2 g) {
  const float c2 = p.gradient_weight_c * p.gradient_weight_c;
  return c2 > 0.0 ? sqrt(c2 / (c2 + dot(g, g))) : 1.0;
}
// Cauchy's weight 1 / (1 + (r / delta)^2), applied as its sqrt like Huber's.
float cauchy_sqrt_weight(float r, float delta) {
  return delta > 0.0 ? inversesqrt(1.0 + (r / delta) * (r / delta)) : 1.0;
}
// sqrt of the weight of the tile holding live pixel (x, y) (ICP_RGB_FLAG_TILE_WEIGHTS; else 1).
float tile_sqrt_weight(int x, int y) {
  if ((p.flags & ICP_RGB_FLAG_TILE_WEIGHTS) == 0u) return 1.0;
  return sqrt(tile_weights[icp_rgb_tile(x, y, int(p.width), int(p.height))]);
}
// A photometric residual's sqrt weight: the robust weight (ICP_RGB_FLAG_CAUCHY: Cauchy's, else
// Huber's, with scale delta) times the gradient weight and the weight of the tile of live pixel (x, y).
float photometric_sqrt_weight(float r, float delta, vec2 g, int x, int y) {
  const float robust = (p.flags & ICP_RGB_FLAG_CAUCHY) != 0u ? cauchy_sqrt_weight(r, delta) : huber_sqrt_weight(r, delta);
  return robust * gradient_sqrt_weight(g) * tile_sqrt_weight(x, y);
}
#endif
// The rectangle's origin (IcpRgbReduceParams::rect_x0y0).
uint rect_x0() { return p.rect_x0y0 & 0xFFFFu; }
uint rect_y0() { return p.rect_x0y0 >> 16u; }
// Weights of the pixels (x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1) at fraction a.
vec4 bilinear_weights(vec2 a) {
  return vec4((1.0 - a.x) * (1.0 - a.y), a.x * (1.0 - a.y), (1.0 - a.x) * a.y, a.x * a.y);
}
// A grid-stride walk over the rectangle's pixels in the order of the flat index ri (ri += stride)
// that keeps ri's row and column instead of dividing by the rectangle's width at every step:
// lavapipe has no vector integer division and divides lane by lane.
struct RectWalk {
  uint ri, row, col;
};
RectWalk rect_walk_start(uint ri) { return RectWalk(ri, ri / p.rect_width, ri % p.rect_width); }
void rect_walk_step(inout RectWalk r, uint stride, uint stride_rows, uint stride_cols) {
  r.ri += stride;
  r.row += stride_rows;
  r.col += stride_cols;
  if (r.col >= p.rect_width) {
    r.col -= p.rect_width;
    r.row += 1u;
  }
}
Term zero_term() {
  const vec4 z = vec4(0.0);
  return Term(z, z, z, z, z, z, z, z);
}

// Whether reference pixel j = (u, v) lies on the prediction's rim: at the image's edge or with a
// 4-neighbour the prediction does not cover. Splatted discs overhang the silhouette there, so the
// rim's fused colours mix the model's with what lay beside it (docs/experiments.md).
bool on_rim(uint j, int u, int v) {
  return u == 0 || v == 0 || u == int(p.width) - 1 || v == int(p.height) - 1 || texel_vec4(ref_vertex, j - 1u).w <= 0.0 ||
         texel_vec4(ref_vertex, j + 1u).w <= 0.0 || texel_vec4(ref_vertex, j - p.width).w <= 0.0 ||
         texel_vec4(ref_vertex, j + p.width).w <= 0.0;
}

void main() {
  const mat3 R = mat3(p.T_reference_live[0], p.T_reference_live[4], p.T_reference_live[8],   // column 0
                      p.T_reference_live[1], p.T_reference_live[5], p.T_reference_live[9],   // column 1
                      p.T_reference_live[2], p.T_reference_live[6], p.T_reference_live[10]); // column 2
  const vec3 t = vec3(p.T_reference_live[3], p.T_reference_live[7], p.T_reference_live[11]);
  const int w = int(p.width), h = int(p.height);
  const uint n = p.rect_width * p.rect_height;
  const float max_d2 = p.max_distance_m * p.max_distance_m;

  Term icp = zero_term(), rgb = zero_term();

  const uint stride = gl_NumWorkGroups.x * ICP_RGB_GROUP_SIZE;
  const uint stride_rows = stride / p.rect_width, stride_cols = stride % p.rect_width;
  for (RectWalk rw = rect_walk_start(gl_GlobalInvocationID.x); rw.ri < n; rect_walk_step(rw, stride, stride_rows, stride_cols)) {
    const uint live_x = rect_x0() + rw.col, live_y = rect_y0() + rw.row;
    const uint i = live_y * p.width + live_x;  // live pixel
    const vec4 v_live = texel_vec4(live_vertex, i);
    if (v_live.w <= 0.0) continue;
    const vec4 n_live = texel_vec4(live_normal, i);
    const bool normal_valid = n_live.w > 0.0;
    if (normal_valid) icp.s7.y += 1.0;  // ICP_RGB_OFFSET_VALID
    const vec3 q = R * v_live.xyz + t;  // live point in the reference frame
    if (q.z <= 0.0) continue;
    const float x = p.fx * q.x / q.z + p.cx, y = p.fy * q.y / q.z + p.cy;
    // Float comparisons first: x, y may be far outside int range.
    if (!(x >= -0.5 && y >= -0.5 && x < float(w) - 0.5 && y < float(h) - 0.5)) continue;
    const int xn = int(floor(x + 0.5)), yn = int(floor(y + 0.5));
    const uint j = uint(yn * w + xn);  // nearest reference pixel
    const vec4 v_ref = texel_vec4(ref_vertex, j);
    if (v_ref.w <= 0.0) continue;

    // A live point well in front of the reference surface occludes it (ICP_RGB_OFFSET_OCCLUDING).
    if (normal_valid && v_ref.z - q.z > p.max_distance_m) icp.s7.z += 1.0;
    // Point-to-plane ICP (eq. 2): r = n_ref . (q - v_ref), J = [n_ref, q x n_ref].
    if (normal_valid) {
      const vec4 n_ref = texel_vec4(ref_normal, j);
      const vec3 d = q - v_ref.xyz;
      if (n_ref.w > 0.0 && dot(d, d) <= max_d2 && dot(R * n_live.xyz, n_ref.xyz) >= p.min_normal_cos) {
        const float r = dot(n_ref.xyz, d);
        const float sw = huber_sqrt_weight(r, p.icp_huber_delta_m) *
                         depth_noise_scale(v_live.z, p.icp_noise_reference_depth_m);
        accumulate(icp, sw * n_ref.xyz, sw * cross(q, n_ref.xyz), sw * r);
      }
    }

    // Photometric (eq. 3): r = I_ref(pi(q)) - g I_live(u), bilinear in the reference, where the
    // four reference samples are valid and the nearest one is not occluding q; g is the live
    // frame's exposure gain (TrackerParams::exposure_compensation).
    if ((p.flags & ICP_RGB_FLAG_PHOTOMETRIC) != 0u && x >= 0.0 && y >= 0.0 && x < float(w - 1) && y < float(h - 1) &&
        abs(q.z - v_ref.z) <= p.max_distance_m) {
      const int x0 = int(floor(x)), y0 = int(floor(y));
      const uint j00 = uint(y0 * w + x0), j10 = j00 + 1u, j01 = j00 + p.width, j11 = j01 + 1u;
      const bool rim = (p.flags & ICP_RGB_FLAG_SKIP_RIM) != 0u && on_rim(j, xn, yn);
      if (!rim && texel_vec4(ref_vertex, j00).w > 0.0 && texel_vec4(ref_vertex, j10).w > 0.0 &&
          texel_vec4(ref_vertex, j01).w > 0.0 && texel_vec4(ref_vertex, j11).w > 0.0) {
        const vec4 wts = bilinear_weights(vec2(x - float(x0), y - float(y0)));
        const float I = dot(wts, vec4(texel_float(ref_intensity, j00), texel_float(ref_intensity, j10),
                                      texel_float(ref_intensity, j01), texel_float(ref_intensity, j11)));
        const float I_live = texel_float(live_intensity, i);
        rgb.s7.y += I;       // ICP_RGB_OFFSET_REF_INTENSITY
        rgb.s7.z += I_live;  // ICP_RGB_OFFSET_LIVE_INTENSITY
        const float r = (I - p.live_intensity_gain * I_live) * (1.0 / 255.0);
        if (abs(r) <= p.max_intensity_diff) {
          vec2 g = (wts.x * texel_vec2(ref_gradient, j00) + wts.y * texel_vec2(ref_gradient, j10) +
                    wts.z * texel_vec2(ref_gradient, j01) + wts.w * texel_vec2(ref_gradient, j11)) * (1.0 / 255.0);
          if ((p.flags & ICP_RGB_FLAG_ESM) != 0u)
            g = 0.5 * (g + p.live_intensity_gain * texel_vec2(live_gradient, i) * (1.0 / 255.0));
          const vec3 dI_dq = intensity_jacobian(g, q);
#ifdef ICP_RGB_REWEIGHTED
          const float sw = photometric_sqrt_weight(r, p.rgb_huber_delta, g, int(live_x), int(live_y));
#else
          const float sw = huber_sqrt_weight(r, p.rgb_huber_delta);
#endif
          accumulate(rgb, sw * dI_dq, sw * cross(q, dI_dq), sw * r);
        }
      }
    }
  }

  // The outline (model -> live): each reference pixel against the unmasked live intensity where
  // the motion puts it, r = g I_live(pi(x)) - I_ref with x = T^-1 v_ref, unless the live depth there
  // is nearer (an occluder). For an increment d applied as exp(d) T, dx = -R^T (d_t + d_w x v_ref),
  // so J = -(G, v_ref x G) with G = R dI/dx.
  if ((p.flags & ICP_RGB_FLAG_PHOTOMETRIC) != 0u && (p.flags & ICP_RGB_FLAG_OUTLINE) != 0u) {
    const mat3 Rt = transpose(R);
    const vec3 t_inv = -(Rt * t);
    for (RectWalk rw = rect_walk_start(gl_GlobalInvocationID.x); rw.ri < n; rect_walk_step(rw, stride, stride_rows, stride_cols)) {
      const int ju = int(rect_x0() + rw.col), jv = int(rect_y0() + rw.row);
      const uint j = uint(jv) * p.width + uint(ju);  // reference pixel
      const vec4 v_ref = texel_vec4(ref_vertex, j);
      if (v_ref.w <= 0.0) continue;
      // The prediction's rim is left out: it held moving objects back (docs/experiments.md).
      if (on_rim(j, ju, jv)) continue;
      const vec3 x_live = Rt * v_ref.xyz + t_inv;
      if (x_live.z <= 0.0) continue;
      const float u = p.fx * x_live.x / x_live.z + p.cx, v = p.fy * x_live.y / x_live.z + p.cy;
      if (!(u >= 0.0 && v >= 0.0 && u < float(w - 1) && v < float(h - 1))) continue;
      const int u0 = int(floor(u)), v0 = int(floor(v));
      // Something nearer than the model point there (another object in front): no outline.
      const float z_live = texel_float(live_depth, uint(int(floor(v + 0.5)) * w + int(floor(u + 0.5))));
      if (z_live > 0.0 && z_live < x_live.z - p.outline_occlusion_margin_m) continue;
      const uint i00 = uint(v0 * w + u0), i10 = i00 + 1u, i01 = i00 + p.width, i11 = i01 + 1u;
      const vec4 wts = bilinear_weights(vec2(u - float(u0), v - float(v0)));
      const float I = dot(wts, vec4(texel_float(live_intensity, i00), texel_float(live_intensity, i10),
                                    texel_float(live_intensity, i01), texel_float(live_intensity, i11)));
      const float r = (p.live_intensity_gain * I - texel_float(ref_intensity, j)) * (1.0 / 255.0);
      if (abs(r) > p.max_intensity_diff) continue;
      const vec2 g = p.live_intensity_gain * (wts.x * texel_vec2(live_gradient, i00) + wts.y * texel_vec2(live_gradient, i10) +
                      wts.z * texel_vec2(live_gradient, i01) + wts.w * texel_vec2(live_gradient, i11)) * (1.0 / 255.0);
      const vec3 G = R * intensity_jacobian(g, x_live);
#ifdef ICP_RGB_REWEIGHTED
      const float sw = photometric_sqrt_weight(r, p.outline_rgb_delta, g, int(floor(u + 0.5)), int(floor(v + 0.5)));
#else
      const float sw = huber_sqrt_weight(r, p.outline_rgb_delta);
#endif
      accumulate(rgb, -sw * G, -sw * cross(v_ref.xyz, G), sw * r);
    }
  }
  // Subgroup sums, one slot per subgroup in shared memory, then one barrier.
  if (gl_SubgroupID < ICP_RGB_MAX_SUBGROUPS) {  // guaranteed by the host; keeps the indexing safe
    const vec4 sums[16] = vec4[16](subgroupAdd(icp.s0), subgroupAdd(icp.s1), subgroupAdd(icp.s2), subgroupAdd(icp.s3),
                                   subgroupAdd(icp.s4), subgroupAdd(icp.s5), subgroupAdd(icp.s6), subgroupAdd(icp.s7),
                                   subgroupAdd(rgb.s0), subgroupAdd(rgb.s1), subgroupAdd(rgb.s2), subgroupAdd(rgb.s3),
                                   subgroupAdd(rgb.s4), subgroupAdd(rgb.s5), subgroupAdd(rgb.s6), subgroupAdd(rgb.s7));
    if (gl_SubgroupInvocationID == 0u)
      for (uint k = 0u; k < 16u; ++k) subgroup_sums[gl_SubgroupID * 16u + k] = sums[k];
  }
  memoryBarrierShared();
  barrier();
  const uint k = gl_LocalInvocationIndex;
  if (k < 16u) {
    vec4 s = vec4(0.0);
    const uint groups = min(gl_NumSubgroups, uint(ICP_RGB_MAX_SUBGROUPS));
    for (uint g = 0u; g < groups; ++g) s += subgroup_sums[g * 16u + k];
    const uint o = gl_WorkGroupID.x * ICP_RGB_PARTIAL_STRIDE + 4u * k;
    partials[o] = s.x;
    partials[o + 1u] = s.y;
    partials[o + 2u] = s.z;
    partials[o + 3u] = s.w;
  }
}
