// Pipeline configuration files (`cofusion run --config`, commands/config.h).
#include "commands/config.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = cofusion::fuzz::write_input("config.json", data, size);
  try {
    cofusion::commands::load_config(path);
  } catch (const cofusion::Error&) {
  }
  return 0;
}
