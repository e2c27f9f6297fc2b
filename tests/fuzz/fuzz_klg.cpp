// .klg logs (io/klg.h): the header walk and every frame's depth and colour block. Images are
// 8x6 pixels so raw blocks stay small enough for the fuzzer to build.
#include "fuzz_input.h"
#include "io/klg.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = cofusion::fuzz::write_input("log.klg", data, size);
  try {
    cofusion::KlgSource source(path, {.intrinsics = "10,10,4,3,8,6"});
    for (int i = 0; i < 64; ++i) {
      try {
        if (!source.next()) break;
      } catch (const cofusion::BadFrame&) {
        // one damaged block: the source goes on with the next frame
      }
    }
  } catch (const cofusion::Error&) {
    // a log that cannot be read: the expected outcome of most inputs
  }
  return 0;
}
