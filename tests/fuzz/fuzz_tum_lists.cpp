// TUM RGB-D text files (io/tum_source.h, io/trajectory.h): rgb.txt/depth.txt lists,
// associations.txt and trajectories (groundtruth.txt), the same bytes through each reader, then
// the time pairing of what the list reader accepted.
#include "fuzz_input.h"
#include "io/trajectory.h"
#include "io/tum_source.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = cofusion::fuzz::write_input("list.txt", data, size);
  try {
    const auto files = cofusion::read_tum_file_list(path);
    cofusion::associate_by_time(files, files, 0.02);
  } catch (const cofusion::Error&) {
  }
  try {
    cofusion::read_tum_associations(path);
  } catch (const cofusion::Error&) {
  }
  try {
    cofusion::read_tum_trajectory(path);
  } catch (const cofusion::Error&) {
  }
  return 0;
}
