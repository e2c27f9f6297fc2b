// cofusion: real-time dense RGB-D SLAM of independently moving objects on Vulkan compute.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "commands/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"cofusion: dense RGB-D SLAM that segments, tracks and fuses moving objects (Vulkan compute)"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Show help for every subcommand");
  cofusion::commands::add_run(app);
  cofusion::commands::add_bench(app);
  cofusion::commands::add_eval(app);
  cofusion::commands::add_generate(app);
  cofusion::commands::add_convert(app);
  cofusion::commands::add_detect(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cofusion: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
