#pragma once
// Each subcommand of `cofusion` registers itself on the CLI11 app. A subcommand's callback throws
// cofusion::Error with a one-line reason on failure; main() prints it and exits non-zero.
#include <CLI/CLI.hpp>

namespace cofusion::commands {

void add_run(CLI::App& app);       // run.cpp:      the SLAM pipeline on a frame source
void add_bench(CLI::App& app);     // bench.cpp:    per-stage timings
void add_eval(CLI::App& app);      // eval.cpp:     trajectory / segmentation / reconstruction metrics
void add_generate(CLI::App& app);  // generate.cpp: write a synthetic scene to disk
void add_convert(CLI::App& app);   // convert.cpp:  convert recordings between formats (e.g. TUM -> klg)
void add_detect(CLI::App& app);    // detect.cpp:   instance masks from the built-in semantic detector

}  // namespace cofusion::commands
