// Intrinsics (io/intrinsics_option.h): calibration files ("fx fy cx cy [w h]") and the
// --intrinsics option's text.
#include "fuzz_input.h"
#include "io/intrinsics_option.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = cofusion::fuzz::write_input("calibration.txt", data, size);
  try {
    cofusion::read_calibration_file(path);
  } catch (const cofusion::Error&) {
  }
  const std::string option = cofusion::fuzz::as_text(data, size);
  // Text naming a file would make the option read it: only numbers and preset names are fuzzed.
  if (option.find('/') != std::string::npos) return 0;
  try {
    cofusion::parse_intrinsics_option(option);
  } catch (const cofusion::Error&) {
  }
  return 0;
}
