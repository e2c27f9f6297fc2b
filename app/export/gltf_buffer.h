#pragma once
// What the two glTF writers (export/gltf_export.h: surfel models; synthetic/gltf_export.h: the
// generator's triangle meshes) share: appending an attribute to a document's single buffer, and
// writing a .glb atomically.
#include <tiny_gltf.h>

#include <cstddef>
#include <filesystem>
#include <vector>

namespace cofusion::gltf {

// Appends `byte_count` bytes to `buffer` (padded first to a 4-byte boundary, which vertex
// attributes require) with a buffer view of buffer 0 and an accessor over it; returns the
// accessor's index. Min/max bounds are the caller's to set.
int append_accessor(tinygltf::Model& doc, std::vector<unsigned char>& buffer, const void* bytes, std::size_t byte_count,
                    int component_type, int type, std::size_t count, int target, bool normalized = false);

// Writes `doc` as binary glTF, atomically; throws cofusion::Error naming the file on failure.
void write_glb(const tinygltf::Model& doc, const std::filesystem::path& path);

}  // namespace cofusion::gltf
