#include "commands/gpu_options.h"

#include <cstdio>

namespace cofusion::commands {

bool handle_list_devices(const GpuCliOptions& options) {
  if (!options.list_devices) return false;
  for (const auto& d : gpu::Context::list_devices())
    std::printf("%u: %s [%s]%s%s\n", d.index, d.name.c_str(), d.type.c_str(), d.usable ? "" : " unusable: ",
                d.why_unusable.c_str());
  return true;
}

}  // namespace cofusion::commands
