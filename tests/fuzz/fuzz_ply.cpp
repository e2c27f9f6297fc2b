// PLY files: the shared vertex reader (io/ply_reader.h), the evaluation's point reader
// (eval/geometry_io.h) and the surfel-model reader (export/ply_export.h), on the same bytes.
#include "eval/geometry_io.h"
#include "export/ply_export.h"
#include "fuzz_input.h"
#include "io/ply_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = cofusion::fuzz::write_input("model.ply", data, size);
  try {
    cofusion::ply::read_vertices(path, {"x", "y", "z", "nx", "red", "radius", "confidence"});
  } catch (const cofusion::Error&) {
  }
  try {
    cofusion::eval::read_ply_points(path);
  } catch (const cofusion::Error&) {
  }
  try {
    cofusion::read_surfel_ply(path);
  } catch (const cofusion::Error&) {
  }
  return 0;
}
