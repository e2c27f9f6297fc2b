// `cofusion convert`: any frame source to a .klg log or a TUM RGB-D folder.
#include <cstdio>

#include "commands/commands.h"
#include "commands/sources.h"
#include "common/error.h"
#include "io/klg.h"
#include "io/tum_writer.h"

namespace cofusion::commands {
namespace {

struct ConvertOptions {
  std::string input;
  std::string to;  // "klg" or "tum"; empty = from --output (.klg file, else folder)
  std::string output;
  std::string intrinsics;
  std::optional<double> depth_correction;
  std::optional<int> max_frames;
  unsigned seed = 0;
  bool raw_depth = false;
  bool raw_colour = false;
  int jpeg_quality = 90;
};

void convert(const ConvertOptions& o) {
  std::string to = o.to;
  if (to.empty()) to = std::filesystem::path(o.output).extension() == ".klg" ? "klg" : "tum";
  if (to != "klg" && to != "tum") throw Error("--to '" + o.to + "': expected 'klg' or 'tum'");
  if (o.jpeg_quality < 0 || o.jpeg_quality > 100)
    throw Error("--jpeg-quality " + std::to_string(o.jpeg_quality) + ": expected 0..100");

  SourceOptions source_options;
  source_options.intrinsics = o.intrinsics;
  source_options.depth_correction = o.depth_correction;
  source_options.max_frames = o.max_frames;
  source_options.seed = o.seed;
  auto source = open_source(o.input, source_options);
  std::printf("input: %s\n", source->describe().c_str());
  std::fflush(stdout);

  int frames = 0;
  if (to == "klg") {
    KlgWriteOptions w;
    w.compress_depth = !o.raw_depth;
    w.jpeg_colour = !o.raw_colour;
    w.jpeg_quality = o.jpeg_quality;
    frames = write_klg(*source, o.output, w);
  } else {
    frames = write_tum_folder(*source, o.output);
  }
  std::printf("wrote %d frames to %s (%s)\n", frames, o.output.c_str(), to.c_str());
}

}  // namespace

void add_convert(CLI::App& app) {
  auto o = std::make_shared<ConvertOptions>();
  auto* cmd = app.add_subcommand("convert", "Convert a frame source to a .klg log or a TUM RGB-D folder");
  cmd->add_option("--input,-i", o->input,
                  "Source: synthetic[:SCENE], tum:PATH, klg:PATH, oni:PATH, openni2[:URI], images:PATH")
      ->required();
  cmd->add_option("--to", o->to, "Output format: klg or tum (default: klg for a .klg output, else tum)")
      ->check(CLI::IsMember({"klg", "tum"}));
  cmd->add_option("--output,-o", o->output, "Output .klg file or TUM folder")->required();
  cmd->add_option("--intrinsics", o->intrinsics, "fx,fy,cx,cy[,w,h] | calibration file | preset (fr1, fr2, fr3, primesense)");
  cmd->add_option("--depth-correction", o->depth_correction,
                  "Recorded depth / DS = metric depth (default: TUM folders of the fr1/fr2 cameras 1.035/1.031, as the TUM benchmark lists; else 1)")
      ->check(CLI::Range(0.5, 2.0));
  cmd->add_option("--max-frames", o->max_frames, "Convert at most this many frames")->check(CLI::NonNegativeNumber);
  cmd->add_option("--seed", o->seed, "Synthetic scenes: noise seed (0 = the scene's own)");
  cmd->add_flag("--raw-depth", o->raw_depth, "klg: store depth uncompressed (default: zlib)");
  cmd->add_flag("--raw-colour", o->raw_colour, "klg: store colour as raw RGB (default: JPEG)");
  cmd->add_option("--jpeg-quality", o->jpeg_quality, "klg: JPEG quality 0..100")->check(CLI::Range(0, 100));
  cmd->callback([o] { convert(*o); });
}

}  // namespace cofusion::commands
