// Struct layouts, binding numbers and the tracker's tile index (icp_rgb_tile) shared by C++ and
// GLSL. Depends on nothing else.
// Rules: scalars and vec4-sized members only (no vec3 in std430 arrays); every struct used on
// the C++ side has static_asserts on size and offsets in compute/gpu/layout_checks.cpp.
#ifndef COFUSION_HOST_DEVICE_H
#define COFUSION_HOST_DEVICE_H

#ifdef __cplusplus
#include <cstdint>
namespace cofusion::gpu_layout {
using uint = std::uint32_t;
#endif

// Every 2D kernel runs 16x16 workgroups (one invocation per output pixel).
#define COFUSION_TILE 16

// ---- depth_to_metres.comp: uint16 depth (packed 2 per uint) -> float metres -------------
#define DEPTH_TO_METRES_BINDING_RAW 0    // uint[]  raw 16-bit units, little-endian pairs
#define DEPTH_TO_METRES_BINDING_DEPTH 1  // float[] metres, 0 = no reading
struct DepthToMetresParams {
  uint width;
  uint height;
  float metres_per_unit;  // 1/5000 for TUM, 1/1000 for OpenNI
  float min_depth_m;      // readings nearer than this become 0
  float max_depth_m;      // readings farther than this become 0 (the depth cut-off)
};

// ---- bilateral_depth.comp: edge-preserving smoothing of metric depth -----------------------
#define BILATERAL_BINDING_SRC 0  // float[] metres
#define BILATERAL_BINDING_DST 1  // float[] metres
struct BilateralParams {
  uint width;
  uint height;
  int radius_px;          // window is (2r+1)^2
  float sigma_space_px;   // spatial Gaussian sigma
  float sigma_depth_m;    // range Gaussian sigma
};

// ---- depth_pyramid.comp / intensity_pyramid.comp: halve resolution -------------------------
#define DOWNSAMPLE_BINDING_SRC 0  // float[]
#define DOWNSAMPLE_BINDING_DST 1  // float[]
struct DownsampleParams {
  uint src_width;
  uint src_height;
  uint dst_width;          // max(1, src_width / 2)
  uint dst_height;         // max(1, src_height / 2)
  float max_depth_diff_m;  // depth only: ignore samples farther than this from the block's first valid one
};

// ---- rgb_to_intensity.comp: RGB8 -> I = (r+g+b)/3 in [0,255] --------------------------------
#define INTENSITY_BINDING_RGB 0        // uint[] packed RGB8 bytes, 3 per pixel
#define INTENSITY_BINDING_INTENSITY 1  // float[]
struct IntensityParams {
  uint width;
  uint height;
};

// ---- vertex_normal_map.comp: metric depth -> camera-frame vertices and normals --------------
#define VERTEX_NORMAL_BINDING_DEPTH 0   // float[] metres
#define VERTEX_NORMAL_BINDING_VERTEX 1  // vec4[] xyz metres, w = 1 valid / 0 invalid
#define VERTEX_NORMAL_BINDING_NORMAL 2  // vec4[] unit normal facing the camera, w = 1 valid / 0 invalid
struct VertexNormalParams {
  uint width;
  uint height;
  float fx;  // pixels, at this pyramid level
  float fy;
  float cx;
  float cy;
};

// ---- intensity_gradient.comp: Sobel gradients of intensity ----------------------------------
#define GRADIENT_BINDING_INTENSITY 0  // float[]
#define GRADIENT_BINDING_GRADIENT 1   // vec2[] (dI/dx, dI/dy) per pixel
struct GradientParams {
  uint width;
  uint height;
  uint x0, y0, x1, y1;  // pixels computed: [x0, x1) x [y0, y1) (reads outside it, clamped at the borders)
};

// ---- stable stream compaction (shared/compaction.glsl, compaction_scan.comp) ----------------
// Kernels that keep some of their elements (fusion's new surfels, cleanup's and remove_region's
// kept surfels) write them in source order, so that runs are repeatable whatever the threads'
// timing. Elements go in blocks of COMPACTION_BLOCK consecutive ones, one workgroup per block:
// a counting pass writes each block's number of kept elements, compaction_scan turns those into
// each block's first destination, and the writing pass puts an element at its block's first
// destination plus the number of kept elements before it in the block. Cleanup and
// remove_region decide once: their counting pass also stores the decisions as a keep mask (a bit
// per element: bit e % 32 of word e / 32), and surfel_compact, the writing pass, only copies.
#define COMPACTION_BLOCK 256
#define COMPACTION_MASK_WORDS (COMPACTION_BLOCK / 32)  // keep-mask words per block
#define COMPACTION_PASS_COUNT 0  // the kernel writes its block's count to the blocks buffer
#define COMPACTION_PASS_WRITE 1  // the kernel writes its kept elements
#define COMPACTION_SCAN_BINDING_BLOCKS 0   // uint[block_count]: counts in, first destinations out
#define COMPACTION_SCAN_BINDING_COUNTER 1  // uint[]: counter[counter_slot] is the first destination of
                                           // block 0 in, the destination after the last kept element out
#define COMPACTION_FIXED_COUNT 0xFFFFFFFFu  // count_slot: scan all block_count blocks
struct CompactionScanParams {
  uint block_count;  // blocks at most
  uint counter_slot;
  // COMPACTION_FIXED_COUNT, or the counter slot that holds the counting pass's number of elements
  // (known only to the GPU): then only the blocks covering min(that count, block_count *
  // COMPACTION_BLOCK) elements are scanned, as an indirect counting pass wrote no others.
  uint count_slot;
  uint pad;
};

// ---- indirect_groups.comp: workgroup counts for a count that only the GPU knows --------------
// One invocation reads n = min(counter[count_slot], bound) and writes two VkDispatchIndirectCommand
// records: (ceil(n / group_size_a), 1, 1) at word 0 and (ceil(n / group_size_b), 1, 1) at word
// INDIRECT_GROUPS_B_WORD, for kernels dispatched over n elements (fusion's maintenance passes:
// the model's count with fusion's new surfels, of which the host knows only a bound).
#define INDIRECT_GROUPS_BINDING_COUNTER 0  // uint[]
#define INDIRECT_GROUPS_BINDING_ARGS 1     // uint[INDIRECT_GROUPS_WORDS]
#define INDIRECT_GROUPS_B_WORD 3
#define INDIRECT_GROUPS_WORDS 6
struct IndirectGroupsParams {
  uint count_slot;
  uint bound;         // elements at most (the host's bound on the count)
  uint group_size_a;  // elements per workgroup of the first record, > 0
  uint group_size_b;  // elements per workgroup of the second record, > 0
};

// ---- surfel models ---------------------------------------------------------------------------
// One surfel of a model, in the model's own frame (the paper's tuple: position, normal, colour,
// weight/confidence, radius, creation and last-seen timestamps). 48 bytes, std430-compatible.
struct Surfel {
  float px, py, pz;      // position, metres, model frame
  float confidence;      // accumulated fusion weight
  float nx, ny, nz;      // unit normal, model frame
  float radius_m;        // disc radius
  uint colour_rgba8;     // R in the low byte
  int created_frame;     // frame index when first fused
  int last_seen_frame;   // frame index of the last fusion
  uint flags;            // reserved for lifecycle bits (e.g. marked for removal)
};

// ---- splat_surfels.comp: project a model's surfels into a view, 64-bit atomicMin of
// (depth bits << 32 | surfel index) per pixel; splat_resolve.comp turns the winners into maps.
#define SPLAT_BINDING_SURFELS 0   // Surfel[]
#define SPLAT_BINDING_DEPTH_INDEX 1  // uint64 as uvec2[] (lo = index, hi = depth bits); all ones = empty
struct SplatParams {
  float T_camera_model[12];   // row-major 3x4: camera-frame point = T * model-frame point
  float fx, fy, cx, cy;       // of the full-resolution camera
  uint width, height;         // of the target grid (full resolution * grid_scale)
  uint surfel_count;
  float min_confidence;       // surfels below this confidence are skipped ...
  int frame;                  // ... unless created within the last recent_window_frames
  int recent_window_frames;
  uint grid_scale;            // 1 for prediction, 4 for fusion's supersampled index map
  uint footprint_px;          // half-size of the square each surfel covers (0 = one pixel)
  // Per covered cell the key depth is where the cell's ray meets the surfel's disc plane, plus
  // offset_penalty_rel * depth * (cell centre's distance in pixels from the surfel's projection)^2:
  // among surfels of one surface the nearest in the image wins, not the nearest to the camera.
  float offset_penalty_rel;
};

#define RESOLVE_BINDING_SURFELS 0
#define RESOLVE_BINDING_DEPTH_INDEX 1
#define RESOLVE_BINDING_VERTEX 2     // vec4[] camera frame, w = 1 valid
#define RESOLVE_BINDING_NORMAL 3     // vec4[]
#define RESOLVE_BINDING_INTENSITY 4  // float[] [0, 255]
#define RESOLVE_BINDING_INDEX 5      // uint[] surfel index, 0xFFFFFFFF = none
struct ResolveParams {
  float T_camera_model[12];
  float fx, fy, cx, cy;
  uint width, height;
  uint pad0, pad1;
  // Pixels written: [x0, x1) x [y0, y1); of those, only the ones in the area
  // [area_x0, area_x1) x [area_y0, area_y1) are resolved, the rest are written empty (so a
  // smaller area than last frame's leaves no stale pixels where the callers cover both).
  uint x0, y0, x1, y1;
  uint area_x0, area_y0, area_x1, area_y1;
};

// ---- subsample_prediction.comp: predicted maps of level l+1 from level l (pixel (2x, 2y)) ----
#define SUBSAMPLE_BINDING_SRC_VERTEX 0
#define SUBSAMPLE_BINDING_SRC_NORMAL 1
#define SUBSAMPLE_BINDING_SRC_INTENSITY 2
#define SUBSAMPLE_BINDING_DST_VERTEX 3
#define SUBSAMPLE_BINDING_DST_NORMAL 4
#define SUBSAMPLE_BINDING_DST_INTENSITY 5
struct SubsampleParams {
  uint src_width, src_height, dst_width, dst_height;
  uint x0, y0, x1, y1;  // destination pixels written: [x0, x1) x [y0, y1)
};

// ---- fuse_associate.comp / fuse_update.comp: projective data association and fusion --------
#define FUSE_BINDING_SURFELS 0
#define FUSE_BINDING_INDEX_MAP 1   // supersampled depth/index map (uvec2[]) from splat_surfels
#define FUSE_BINDING_VERTEX 2      // live vec4[] camera frame
#define FUSE_BINDING_NORMAL 3      // live vec4[]
#define FUSE_BINDING_RGB 4         // live RGB8 bytes packed in uint[]
#define FUSE_BINDING_ASSOC 5       // uint[] per live pixel: surfel index, 0xFFFFFFFF none, 0xFFFFFFFE skip
#define FUSE_BINDING_CLAIM 6       // uint[] per surfel: lowest live pixel index associated
#define FUSE_BINDING_COUNTER 7     // uint[4]: [0] surfel count (new surfels added by compaction_scan)
#define FUSE_BINDING_LABELS 8      // uint[] per live pixel: model label (read unless label_mask == FUSE_ALL_LABELS)
// fuse_update only: the surfel buffer again, written here while FUSE_BINDING_SURFELS reads it
// through its texel view. Safe: a surfel is read and written only by the pixel that claimed it,
// and appended surfels lie beyond every surfel that is read.
#define FUSE_BINDING_SURFELS_OUT 9
// fuse_count_new and fuse_update: per block of COMPACTION_BLOCK pixels of the rectangle (row-major),
// the count of new surfels (fuse_count_new), then their first slot (compaction_scan)
#define FUSE_BINDING_BLOCKS 10
#define FUSE_NO_SURFEL 0xFFFFFFFFu
#define FUSE_SKIP_PIXEL 0xFFFFFFFEu
#define FUSE_ALL_LABELS 0xFFFFFFFFu  // FuseParams::label_mask: no label image, every pixel is fused
// Whether a pixel's label is one of a label mask's (bit l for label l; labels from 32 up are in none).
#define LABEL_IN_MASK(label, mask) ((label) < 32u && (((mask) >> (label)) & 1u) != 0u)
struct FuseParams {
  float T_camera_model[12];   // current pose of the model in the camera (inverted in the shader)
  float fx, fy, cx, cy;
  uint width, height;         // live image
  uint grid_scale;            // of the index map
  uint surfel_count;          // before this frame's new surfels
  uint capacity;              // of the surfel buffer
  int frame;
  float max_depth_diff_rel;   // association: |z_surfel - z_live| <= max_depth_diff_rel * z_live + 0.005
  float min_normal_dot;       // association: cos(max normal angle)
  float max_radius_growth;    // merge position/normal only if live radius <= this * surfel radius
  // Only pixels whose label is in this mask (LABEL_IN_MASK) are fused; FUSE_ALL_LABELS: every pixel
  // (no label image).
  uint label_mask;
  // Only live pixels in [rect_x0, rect_x1) x [rect_y0, rect_y1) are associated and fused (a
  // model's labelled pixels); association entries and index-map rows outside are not touched.
  uint rect_x0, rect_y0, rect_x1, rect_y1;
  // The live colour is multiplied by this before it is fused: the frame's exposure gain against
  // the model (TrackerParams::exposure_compensation), so a model keeps one exposure; 1 = as read.
  float colour_gain;
  // A pixel that no surfel of its block explains spawns a new surfel only when no surfel within
  // this many cells around the block agrees in depth either (0: the block alone decides).
  uint new_surfel_clearance_cells;
};

// ---- surfel_cleanup.comp: drop unstable / free-space-violating surfels, compact the rest ----
// The counting pass of a compaction (see compaction) whose writing pass is surfel_compact: each
// kept surfel goes, as it stays (merged, free-space penalty applied), to DECIDED at its own index.
#define CLEANUP_BINDING_SRC 0
#define CLEANUP_BINDING_DECIDED 1       // Surfel[] (written only at kept surfels' indices)
#define CLEANUP_BINDING_DEPTH 2     // live depth (metres) at full resolution
#define CLEANUP_BINDING_COUNTER 3   // uint[4]: [0] count to scan, [1] kept count (compaction_scan)
#define CLEANUP_BINDING_MERGE_TARGET 4  // uint[] per surfel, from surfel_merge_select (read when merge != 0)
#define CLEANUP_BINDING_MERGE_CLAIM 5   // uint[] per surfel, from surfel_merge_claim (read when merge != 0)
#define CLEANUP_BINDING_BLOCKS 6        // uint[] per block of COMPACTION_BLOCK surfels: kept count
#define CLEANUP_BINDING_KEEP_MASK 7     // uint[COMPACTION_MASK_WORDS] per block: a bit per kept surfel
struct CleanupParams {
  float T_camera_model[12];
  float fx, fy, cx, cy;
  uint width, height;
  uint surfel_count;             // upper bound of counter[0] (the dispatch size)
  int frame;
  float stable_confidence;       // surfels at or above are stable
  int unstable_window_frames;    // unstable surfels older than this are removed
  float free_space_margin_rel;   // a surfel (this * live depth) in front of the live surface is in free space
  float free_space_penalty;      // confidence removed per free-space violation
  // 1: apply the merges that surfel_merge_select/claim chose: a surfel i with target t, where t
  // has no target itself and claim[t] == i, is dropped; a surfel i with claim[i] = c != MERGE_NONE
  // becomes merge_surfels(i, c) (confidence-weighted average, confidences summed).
  uint merge;
};

// ---- surfel_merge_select.comp, surfel_merge_claim.comp: duplicate surfels --------------------
// After fusion's update (before cleanup), each surfel i looks at every window_step-th cell (in x
// and y) of fusion's supersampled index map within window_cells of its projection, in the part
// of the image this fusion covered (cells of pixels in the rectangle and, with use_labels, of its
// labels). A surfel j found there that is more confident (equal confidence: lower index), lies
// within distance_rel * max(radius_i, radius_j) of i and has a normal within acos(min_normal_dot)
// of i's is a merge target; i takes the nearest (ties: lowest index) as target[i] (MERGE_NONE: none).
// surfel_merge_claim then claims each target that has no target of its own for the lowest such
// source index (atomicMin: order-independent), so every surfel takes part in at most one merge
// per frame and the result does not depend on thread order. surfel_cleanup applies the merges.
#define MERGE_BINDING_SURFELS 0    // Surfel[] (texel view), after fusion's update and appends
#define MERGE_BINDING_INDEX_MAP 1  // fusion's supersampled index map: uint64 keys (texel view), low word = surfel
#define MERGE_BINDING_TARGET 2     // uint[] per surfel: written by select, read by claim
#define MERGE_BINDING_CLAIM 3      // uint[] per surfel: lowest source merging into it (MERGE_NONE: none); claim only
#define MERGE_BINDING_COUNTER 4    // uint[4]: [0] surfel count after fusion's appends
#define MERGE_BINDING_LABELS 5     // uint[] per live pixel (read when use_labels)
#define MERGE_NONE 0xFFFFFFFFu
// shared/small_division.glsl's quotients are exact for dividends below this: the merge search's
// index-map cells (the host checks the map's width and height) and fusion's rectangle pixels
// (shared/fuse_rect.glsl divides as integers at and above it).
#define SMALL_QUOTIENT_LIMIT (1u << 20)
struct MergeParams {
  float T_camera_model[12];   // pose of the index map's camera
  float fx, fy, cx, cy;       // of the full-resolution camera
  uint width, height;         // live image (the index map has width*grid_scale x height*grid_scale cells)
  uint grid_scale;
  uint surfel_count;          // upper bound of counter[0] (the dispatch size)
  // Live pixels whose cells are searched: [rect_x0, rect_x1) x [rect_y0, rect_y1) (the fusion's
  // rectangle: the index map's rows outside it are stale) and, with use_labels, whose label is
  // in label_mask (LABEL_IN_MASK).
  uint rect_x0, rect_y0, rect_x1, rect_y1;
  uint window_cells;          // half-size of the square of cells searched around the projection
  float distance_rel;         // merge when |p_i - p_j| < distance_rel * max(radius_i, radius_j)
  float min_normal_dot;       // ... and dot(n_i, n_j) >= min_normal_dot
  uint use_labels;
  uint label_mask;
  float max_source_confidence;  // only surfels below this confidence look for a target
  uint window_step;           // cells from one searched cell to the next, in x and y (from -window_cells)
};

// ---- surfel_remove_region.comp: remove the surfels that a labelled live region covers ----------
// (Co-Fusion: when part of the background starts moving as its own model, the background's copy
// goes.) A surfel projecting (nearest pixel) onto a live pixel labelled `label` with a depth d > 0
// is removed when z_surfel < d * (1 + margin_rel); surfels behind that (occluded) stay. The
// counting pass of a compaction (see compaction) whose writing pass, surfel_compact, copies the
// kept ones in their order.
#define REMOVE_REGION_BINDING_SRC 0
#define REMOVE_REGION_BINDING_KEEP_MASK 1  // uint[COMPACTION_MASK_WORDS] per block: a bit per kept surfel
#define REMOVE_REGION_BINDING_DEPTH 2    // live depth (metres) at full resolution, 0 = no reading
#define REMOVE_REGION_BINDING_LABELS 3   // uint[] per live pixel
#define REMOVE_REGION_BINDING_COUNTER 4  // uint[4]: [0] count to scan, [1] kept count (compaction_scan)
#define REMOVE_REGION_BINDING_BLOCKS 5   // uint[] per block of COMPACTION_BLOCK surfels: kept count
struct RemoveRegionParams {
  float T_camera_model[12];
  float fx, fy, cx, cy;
  uint width, height;         // live image
  uint surfel_count;          // upper bound of counter[0] (the dispatch size)
  uint label;                 // live pixels with this label are the region
  float margin_rel;           // surfels with z < d * (1 + margin_rel) are removed
  uint pad0, pad1, pad2;
};

// ---- surfel_compact.comp: the writing pass of cleanup's and remove_region's compaction -------
// Copies the surfels the keep mask marks, in their order, to DST from their block's first
// destination (compaction_scan's result) on. No parameters; one workgroup per block.
#define SURFEL_COMPACT_BINDING_SRC 0        // texel view of Surfel[]
#define SURFEL_COMPACT_BINDING_DST 1        // Surfel[]
#define SURFEL_COMPACT_BINDING_BLOCKS 2     // uint[] per block: first destination
#define SURFEL_COMPACT_BINDING_KEEP_MASK 3  // uint[COMPACTION_MASK_WORDS] per block

// ---- mask_vertices.comp: a level's live vertex map restricted to some models' labels --------
// dst[x, y] = src[x, y] where the level-0 label at (x << level, y << level) (clamped to the
// level-0 image) is < 32 and its bit is set in keep_mask; vec4(0) elsewhere.
#define MASK_VERTICES_BINDING_SRC 0     // vec4[] level vertex map, w = 1 valid
#define MASK_VERTICES_BINDING_DST 1     // vec4[] same size
#define MASK_VERTICES_BINDING_LABELS 2  // uint[] per level-0 pixel: model slot 0..31, >= 32 none
#define MASK_VERTICES_NO_LABEL 32u      // (and any larger value)
struct MaskVerticesParams {
  uint width, height;                 // of the level
  uint level0_width, level0_height;   // of the label map
  uint level;
  uint keep_mask;                     // bit k set: keep pixels labelled k
  // Only level pixels in [rect_x0, rect_x1) x [rect_y0, rect_y1) are written; the rest of dst is
  // left as it is (a model's tracking reads only its own rectangle).
  uint rect_x0, rect_y0, rect_x1, rect_y1;
};

// ---- motion_residual.comp: per-pixel alignment cost of the live frame against one model -----
// Projective association as icp_rgb_reduce.comp (nearest reference pixel of T * v_live). Output
// per live pixel (vec4): x = |n_ref . (q - v_ref)| metres (|q - v_ref| when n_ref is invalid),
// y = q.z - v_ref.z metres (> 0: live surface behind the model's), z = |I_ref - I_live| / 255,
// w = status (MOTION_STATUS_*); x, y, z are 0 unless w = MOTION_STATUS_ASSOCIATED.
#define MOTION_RESIDUAL_BINDING_LIVE_VERTEX 0     // vec4[] live camera frame, w = 1 valid
#define MOTION_RESIDUAL_BINDING_LIVE_INTENSITY 1  // float[] [0, 255]
#define MOTION_RESIDUAL_BINDING_REF_VERTEX 2      // vec4[] reference camera frame, w = 1 valid
#define MOTION_RESIDUAL_BINDING_REF_NORMAL 3      // vec4[] w = 1 valid
#define MOTION_RESIDUAL_BINDING_REF_INTENSITY 4   // float[] [0, 255]
#define MOTION_RESIDUAL_BINDING_OUT 5             // vec4[] per live pixel
#define MOTION_STATUS_ASSOCIATED 1.0
#define MOTION_STATUS_NO_LIVE 0.0      // no valid live vertex
#define MOTION_STATUS_NO_MODEL (-1.0)  // live vertex valid, but the model has no geometry there
struct MotionResidualParams {
  float T_reference_live[12];  // row-major 3x4: reference-frame point = T * live-frame point
  float fx, fy, cx, cy;        // level-0 intrinsics (live and reference alike)
  uint width, height;
  // Only live pixels in [rect_x0, rect_x1) x [rect_y0, rect_y1) are written; the rest of the
  // output is left as it is (the host treats it as "no geometry" for this model).
  uint rect_x0, rect_y0, rect_x1, rect_y1;
  // The live intensity is multiplied by this before it is compared with the reference's (the
  // model's tracking's exposure gain, TrackerParams::exposure_compensation; 1 = none).
  float live_intensity_gain;
};

// ---- test_fill.comp: used by the compute-core tests only -------------------------------------
#define TEST_FILL_BINDING_DST 0
struct TestFillParams {
  uint count;
  uint value_offset;  // dst[i] = i + value_offset
};

// ---- test_compaction.comp: used by the compaction tests only ---------------------------------
// Stable compaction of the indices of the nonzero flags: out[k] = index of the k-th nonzero flag.
#define TEST_COMPACTION_BINDING_FLAGS 0   // uint[count]
#define TEST_COMPACTION_BINDING_BLOCKS 1  // uint[] per block of COMPACTION_BLOCK flags
#define TEST_COMPACTION_BINDING_OUT 2     // uint[] kept indices
struct TestCompactionParams {
  uint count;
  uint pass;  // COMPACTION_PASS_COUNT or COMPACTION_PASS_WRITE
};

// ---- test_texel_read.comp: used by the compute-core tests only ------------------------------
#define TEST_TEXEL_BINDING_SRC 0  // texel view
#define TEST_TEXEL_BINDING_DST 1
struct TestTexelParams {
  uint words;  // 32-bit words to copy
  uint mode;   // helper: 0 uint, 1 float, 2 vec2, 3 vec4, 4 64-bit, 5 Surfel
};

// ---- icp_rgb_reduce.comp: one Gauss-Newton iteration of frame-to-model tracking -------------
// Each workgroup loops over the live pixels (grid-stride) and writes ICP_RGB_PARTIAL_STRIDE
// floats of partial sums: the ICP term (point-to-plane, metres) at ICP_RGB_OFFSET_ICP, the count
// of live pixels with a valid vertex and normal at ICP_RGB_OFFSET_VALID, of those the ones lying
// in front of the reference surface by more than max_distance_m (occluders in the reference's
// free space: a person walking in front of the background) at ICP_RGB_OFFSET_OCCLUDING, the
// photometric term (intensity / 255) at ICP_RGB_OFFSET_RGB, and over the pixels of the direct
// photometric term that are geometrically valid (before its intensity outlier test) the sums of
// the reference intensity and of the (ungained) live intensity at ICP_RGB_OFFSET_REF_INTENSITY and
// ICP_RGB_OFFSET_LIVE_INTENSITY (their ratio is the next iteration's exposure gain); the other
// floats are 0.
// Each 29-value term: the 21 entries of the upper triangle of J^T J (row-major: (0,0), (0,1) ..
// (0,5), (1,1) .. (5,5)), the 6 entries of J^T r, sum r^2 and the number of residuals. J is the
// derivative with respect to a left-composed twist (v, w) (see compute/common/se3.h).
#define ICP_RGB_BINDING_LIVE_VERTEX 0     // vec4[] live camera frame, metres, w = 1 valid
#define ICP_RGB_BINDING_LIVE_NORMAL 1     // vec4[] w = 1 valid
#define ICP_RGB_BINDING_LIVE_INTENSITY 2  // float[] [0, 255]
#define ICP_RGB_BINDING_REF_VERTEX 3      // vec4[] reference camera frame, metres, w = 1 valid
#define ICP_RGB_BINDING_REF_NORMAL 4      // vec4[] w = 1 valid
#define ICP_RGB_BINDING_REF_INTENSITY 5   // float[] [0, 255]
#define ICP_RGB_BINDING_REF_GRADIENT 6    // vec2[] d intensity / d pixel, [0, 255] per pixel
#define ICP_RGB_BINDING_PARTIALS 7        // float[workgroups * ICP_RGB_PARTIAL_STRIDE]
#define ICP_RGB_BINDING_LIVE_GRADIENT 8   // vec2[] live d intensity / d pixel (read when esm_gradient != 0)
#define ICP_RGB_BINDING_LIVE_DEPTH 9      // float[] live depth, metres, not masked (the outline term's occlusion test)
// float[ICP_RGB_TILES_X * ICP_RGB_TILES_Y], row-major: the weight of the photometric residuals of
// live pixels in each tile of the level (ICP_RGB_FLAG_TILE_WEIGHTS; icp_rgb_reduce_reweighted.comp
// only, which has this eleventh binding).
#define ICP_RGB_BINDING_TILE_WEIGHTS 10
#define ICP_RGB_TILES_X 8  // tiles across a level (icp_rgb_tile)
#define ICP_RGB_TILES_Y 6
#define ICP_RGB_GROUP_SIZE 256            // invocations per workgroup
#define ICP_RGB_TERM_VALUES 29            // values per term (see above)
#define ICP_RGB_OFFSET_ICP 0
#define ICP_RGB_OFFSET_VALID 29
#define ICP_RGB_OFFSET_OCCLUDING 30
#define ICP_RGB_OFFSET_RGB 32
#define ICP_RGB_OFFSET_REF_INTENSITY 61
#define ICP_RGB_OFFSET_LIVE_INTENSITY 62
// IcpRgbReduceParams::flags
#define ICP_RGB_FLAG_PHOTOMETRIC 1u  // without it the photometric sums stay zero
// Photometric Jacobian from the mean of the reference's intensity gradient at the warped point and
// the live gradient at the pixel (efficient second-order minimisation), not the reference's alone.
#define ICP_RGB_FLAG_ESM 2u
// Also every reference pixel in the rect against the live intensity where the motion puts it
// (r = g I_live(pi(T^-1 v_ref)) - I_ref, live gradient), added to the photometric sums. The live
// intensity is not masked, so a model whose outline lags its object sees the background there:
// the outline constrains motions the object's own pixels do not (TrackerParams).
#define ICP_RGB_FLAG_OUTLINE 4u
// Photometric residuals get Cauchy's weight 1 / (1 + (r / rgb_huber_delta)^2) instead of Huber's
// (TrackerParams::photometric_cauchy_k). Read only by icp_rgb_reduce_reweighted.comp.
#define ICP_RGB_FLAG_CAUCHY 8u
// Photometric residuals of a live pixel (the outline term: of the live pixel nearest to where the
// motion puts the model's) are weighted by its tile's ICP_RGB_BINDING_TILE_WEIGHTS entry
// (CameraCheckParams::photometric_tile_cap). Read only by icp_rgb_reduce_reweighted.comp.
#define ICP_RGB_FLAG_TILE_WEIGHTS 16u
// The live -> reference photometric term leaves out live pixels whose nearest reference pixel is
// on the prediction's rim (a 4-neighbour uncovered, or the image's edge), as the outline term
// always does (TrackerParams::photometric_skip_rim).
#define ICP_RGB_FLAG_SKIP_RIM 32u
#define ICP_RGB_PARTIAL_STRIDE 64         // floats per workgroup (16 vec4)
#define ICP_RGB_MAX_SUBGROUPS 64          // shared memory holds this many subgroups: subgroup size >= 4
struct IcpRgbReduceParams {
  float T_reference_live[12];  // row-major 3x4 [R | t]: reference-frame point = T * live-frame point
  float fx, fy, cx, cy;        // intrinsics of this pyramid level (live and reference alike), pixels
  uint width, height;          // of this level (live and reference alike)
  float max_distance_m;        // ICP: |T v_live - v_ref| above this is no correspondence
  float min_normal_cos;        // ICP: cos of the largest angle between R n_live and n_ref
  float max_intensity_diff;    // photometric: |r| above this (intensity / 255) is an outlier
  uint flags;                  // ICP_RGB_FLAG_*
  // Only live pixels in [rect_x0, rect_x0 + rect_width) x [rect_y0, rect_y0 + rect_height) take
  // part (a model's own pixels; the rest of its masked live map is invalid anyway).
  // rect_x0y0 = rect_x0 | rect_y0 << 16 (the push constants' 128 bytes are all used).
  uint rect_x0y0;
  // Outline term: its residuals' robust scale, as rgb_huber_delta is the live -> reference term's
  // (TrackerParams::outline_huber_scale times it).
  float outline_rgb_delta;
  uint rect_width, rect_height;
  // Photometric: residuals beyond this (intensity / 255) get Huber weight delta / |r| (the sums
  // then hold w J^T J, w J^T r, w r^2); with ICP_RGB_FLAG_CAUCHY it is Cauchy's scale; 0 = none.
  float rgb_huber_delta;
  // Photometric: the live intensity (and its gradient) is multiplied by this before it is compared
  // with the reference's (exposure compensation; 1 = none).
  float live_intensity_gain;
  // Outline term: a model pixel whose live depth there is nearer by more than this is occluded.
  float outline_occlusion_margin_m;
  // ICP: point-to-plane residuals beyond this (metres) get Huber weight delta / |r|, like the
  // photometric ones; 0 = none.
  float icp_huber_delta_m;
  // ICP: a live point deeper than this (metres) has its residual and Jacobian scaled by
  // sigma(reference) / sigma(depth) (shared/depth_noise.h); 0 = no scaling.
  float icp_noise_reference_depth_m;
  // Photometric: each residual (and Jacobian) is scaled by sqrt(c^2 / (c^2 + |g|^2)), g its
  // intensity gradient (intensity / 255 per pixel) and c this; 0 = no scaling.
  float gradient_weight_c;
};


// ---- view_splat.comp / view_resolve.comp: the viewer's offscreen renderer (renderer/) ------
// Several models share one depth/index grid: model k's surfel i gets the key index
// index_base_k + i, so the winner of a pixel names its model. view_resolve runs once per model
// and shades only the pixels that model won. Models are only read.
#define VIEW_SPLAT_BINDING_SURFELS 0
#define VIEW_SPLAT_BINDING_DEPTH_INDEX 1  // uint64 per pixel (hi = depth bits, lo = key index); all ones = empty
#define VIEW_RESOLVE_BINDING_SURFELS 0
#define VIEW_RESOLVE_BINDING_DEPTH_INDEX 1
#define VIEW_RESOLVE_BINDING_IMAGE 2      // uint[] RGBA8 per pixel, R in the low byte
#define VIEW_COLOUR_RGB 0u
#define VIEW_COLOUR_LABEL 1u
#define VIEW_COLOUR_NORMAL 2u
#define VIEW_COLOUR_CONFIDENCE 3u
struct ViewSplatParams {
  float T_view_model[12];   // row-major 3x4: view-frame point = T * model-frame point
  float fx, fy, cx, cy;     // virtual camera, pixels
  uint width, height;       // image size
  uint surfel_count;
  uint index_base;          // first key index of this model
  float min_confidence;     // surfels below are not drawn
  uint max_footprint_px;    // half-size cap of the square a surfel covers
  float near_m;             // surfels nearer than this are clipped
  uint pad0;
};
struct ViewResolveParams {
  float T_view_model[12];
  uint width, height;
  uint surfel_count;
  uint index_base;
  uint colour_mode;         // VIEW_COLOUR_*
  uint label_rgba8;         // the model's palette colour (label mode)
  float confidence_max;     // confidence mapped to the top of the colour map
  float ambient;            // shading: ambient + (1 - ambient) * |cos(normal, view ray)|
};

// The tile (row-major, of ICP_RGB_TILES_X x ICP_RGB_TILES_Y) holding pixel (x, y) of a
// width x height image: the tracker's tile weights (ICP_RGB_BINDING_TILE_WEIGHTS), on the GPU, in
// its CPU reference and where the host computes them.
#ifdef __cplusplus
inline
#endif
int icp_rgb_tile(int x, int y, int width, int height) {
  const int tx = x * ICP_RGB_TILES_X / width, ty = y * ICP_RGB_TILES_Y / height;
  return (ty < ICP_RGB_TILES_Y - 1 ? ty : ICP_RGB_TILES_Y - 1) * ICP_RGB_TILES_X +
         (tx < ICP_RGB_TILES_X - 1 ? tx : ICP_RGB_TILES_X - 1);
}

#ifdef __cplusplus
}  // namespace cofusion::gpu_layout
#endif
#endif  // COFUSION_HOST_DEVICE_H
