// glTF 2.0 meshes of the evaluation (eval/geometry_io.h): binary .glb when the input starts with
// glTF's magic, else .gltf text.
#include <cstring>

#include "eval/geometry_io.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  const auto path = cofusion::fuzz::write_input(binary ? "mesh.glb" : "mesh.gltf", data, size);
  try {
    cofusion::eval::read_gltf_triangles(path);
  } catch (const cofusion::Error&) {
  }
  return 0;
}
