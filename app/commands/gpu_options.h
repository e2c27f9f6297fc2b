#pragma once
// Command-line options shared by the subcommands that use the Vulkan device.
#include <CLI/CLI.hpp>
#include <string>

#include "gpu/context.h"

namespace cofusion::commands {

struct GpuCliOptions {
  std::string device;       // --device: index or name substring
  bool validation = false;  // --validation
  bool list_devices = false;
  uint32_t queues = 0;      // --queues: at most this many compute queues (0: the device's default)

  void add_to(CLI::App& cmd) {
    cmd.add_option("--device", device, "Vulkan device by index or name substring (default: best; a real GPU is preferred)");
    cmd.add_flag("--validation", validation, "Enable Vulkan validation layers (errors are reported and fail the run)");
    cmd.add_flag("--list-devices", list_devices, "List Vulkan devices and exit");
    cmd.add_option("--queues", queues, "Use at most this many compute queues (default: 1 on NVIDIA, where more were slower; elsewhere all the device offers, up to 8)")
        ->check(CLI::NonNegativeNumber);
  }
  gpu::ContextOptions context_options() const {
    gpu::ContextOptions o;
    o.device = device;
    o.validation = validation;
    o.max_compute_queues = queues;
    return o;
  }
};

// Prints the device list; returns true when --list-devices was given (the caller then exits).
bool handle_list_devices(const GpuCliOptions& options);

}  // namespace cofusion::commands
