// Class tables of instance masks (io/instance_classes.h). A table that reads is also written and
// read back: the round trip must give the same table.
#include <cstdlib>

#include "fuzz_input.h"
#include "io/instance_classes.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = cofusion::fuzz::write_input("masks/classes.txt", data, size);
  try {
    const cofusion::InstanceClasses table = cofusion::read_instance_classes(path);
    const std::string text = cofusion::format_instance_classes(table);
    const auto copy = cofusion::fuzz::write_input("copy/classes.txt", reinterpret_cast<const std::uint8_t*>(text.data()),
                                                  text.size());
    if (cofusion::read_instance_classes(copy).name_by_id != table.name_by_id) std::abort();
  } catch (const cofusion::Error&) {
  }
  return 0;
}
