#pragma once
// Surfel models as binary little-endian PLY (MeshLab, CloudCompare, Open3D read it).
//
// One `vertex` element, 35 bytes a vertex:
//   float x y z         position, metres
//   float nx ny nz      unit normal
//   uchar red green blue
//   float radius        disc radius, metres
//   float confidence    fusion weight
// Header comments record the model: "comment model_id <id>", "comment class_name <name>" (when
// known), "comment state <active|inactive|deleted>", "comment frame <model|world>" and
// "comment T_world_model <r00 r01 r02 tx r10 ... tz>" (row-major 3x4), which read_surfel_ply
// parses back.
#include <filesystem>

#include "common/surfel_cloud.h"

namespace cofusion {

enum class PlyFrame {
  Model,  // vertices in the model's own frame, as the glTF vertices (default)
  World,  // vertices and normals mapped by T_world_model: the scene as last seen
};

struct PlyOptions {
  // Surfels with confidence below this (fusion weight, unitless) are left out. 0 keeps all.
  float min_confidence = 0.0f;
  PlyFrame frame = PlyFrame::Model;
};

// Writes the surfels chosen by select_surfels() (same points and order as the glTF writer),
// atomically. Throws cofusion::Error naming the path when it cannot be written or the pose is not
// finite.
void write_model_ply(const SurfelCloud& model, const std::filesystem::path& path, const PlyOptions& options = {});

struct PlyModel {
  // Surfels as stored. Not stored in PLY, so left at their defaults: created_frame,
  // last_seen_frame, flags (0) and the alpha byte of colour_rgba8 (255). model_id, class_name,
  // state and T_world_model come from the header comments when present.
  SurfelCloud cloud;
  PlyFrame frame = PlyFrame::Model;  // the frame the vertices are in ("comment frame"; model if absent)
};

// Reads PLY files (ascii, binary little- or big-endian; io/ply_reader.h) with a vertex element
// holding at least x, y, z; nx ny nz, red green blue, radius and confidence are read when present
// (any PLY scalar type) and default to 0 (colour: white) otherwise. Throws cofusion::Error naming
// the file on anything else (truncated data, missing x/y/z, a malformed model comment).
PlyModel read_surfel_ply(const std::filesystem::path& path);

}  // namespace cofusion
