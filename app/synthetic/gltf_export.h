#pragma once
// Triangle meshes as binary glTF 2.0 (.glb): one mesh, one node, positions + normals + vertex
// colours (COLOR_0, linear 0..1) + 32-bit indices.
#include <filesystem>
#include <string>

#include "synthetic/geometry.h"

namespace cofusion::synthetic {

// Written atomically; throws cofusion::Error naming the file on failure.
void write_glb(const Mesh& mesh, const std::string& name, const std::filesystem::path& path);

// Reads back the first triangle primitive of a .glb written by write_glb (positions, normals,
// colours, indices). Throws cofusion::Error naming the file when it is missing or not such a file.
Mesh read_glb(const std::filesystem::path& path);

}  // namespace cofusion::synthetic
