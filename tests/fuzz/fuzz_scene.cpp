// Scene descriptions (synthetic/scene.h), parsed as `cofusion generate --scene FILE` does.
#include "fuzz_input.h"
#include "synthetic/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    cofusion::synthetic::parse_scene(cofusion::fuzz::as_text(data, size), "fuzz input");
  } catch (const cofusion::Error&) {
  }
  return 0;
}
