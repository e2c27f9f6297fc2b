// `cofusion generate`: render a synthetic scene with its ground truth into a TUM RGB-D folder
// (layout in synthetic/dataset_writer.h).
#include <chrono>
#include <cstdio>

#include "commands/commands.h"
#include "common/error.h"
#include "synthetic/dataset_writer.h"
#include "synthetic/scene.h"
#include "synthetic/synthetic_source.h"

namespace cofusion::commands {
namespace {

struct GenerateOptions {
  std::string scene;  // built-in name or .json path; empty = default scene
  std::string output;
  unsigned seed = 0;
  std::optional<int> max_frames;
  bool no_noise = false;
  bool overwrite = false;
  bool list = false;
};

void list_scenes() {
  for (const std::string& name : synthetic::builtin_scene_names()) {
    const synthetic::SceneDescription s = synthetic::load_scene(name);
    std::printf("%-16s %4d frames, %zu objects%s  %s\n", name.c_str(), s.frames, s.objects.size(),
                name == synthetic::kDefaultScene ? " (default)" : "", s.description.c_str());
  }
}

void generate(const GenerateOptions& o) {
  if (o.list) {
    list_scenes();
    return;
  }
  if (o.output.empty()) throw Error("generate: --output DIR is required");
  synthetic::SyntheticSequence sequence(synthetic::load_scene(o.scene), o.seed, o.max_frames);
  if (o.no_noise) sequence.set_noise(synthetic::KinectNoiseParams::none());
  std::printf("scene %s: %d frames, %d objects, %s\n", sequence.scene().name.c_str(), sequence.size(),
              sequence.object_count(),
              o.no_noise ? "no noise" : ("noise seed " + std::to_string(sequence.noise_seed())).c_str());
  std::fflush(stdout);

  synthetic::DatasetOptions options;
  options.overwrite = o.overwrite;
  const auto start = std::chrono::steady_clock::now();
  options.progress = [](int done, int total) {
    if (done % 30 == 0 || done == total) {
      std::printf("  %d/%d frames\n", done, total);
      std::fflush(stdout);
    }
  };
  synthetic::write_tum_dataset(sequence, o.output, options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("wrote %s (%d frames in %.1f s)\n", o.output.c_str(), sequence.size(), seconds);
}

}  // namespace

void add_generate(CLI::App& app) {
  auto o = std::make_shared<GenerateOptions>();
  auto* cmd = app.add_subcommand("generate",
                                 "Render a synthetic dynamic scene with ground truth (poses, masks, meshes) into a "
                                 "TUM RGB-D folder");
  cmd->add_option("scene", o->scene,
                  "Built-in scene name (see --list) or path to a scene .json (default: " +
                      std::string(synthetic::kDefaultScene) + ")");
  cmd->add_option("--output,-o", o->output, "Output folder (must not exist or be empty, unless --overwrite)");
  cmd->add_option("--seed", o->seed, "Noise seed (0 = the scene's own); poses do not depend on it");
  cmd->add_option("--max-frames", o->max_frames, "Write at most this many frames")->check(CLI::NonNegativeNumber);
  cmd->add_flag("--no-noise", o->no_noise, "Exact depth and clean colour (no sensor noise)");
  cmd->add_flag("--overwrite", o->overwrite, "Replace a non-empty output folder");
  cmd->add_flag("--list", o->list, "List the built-in scenes and exit");
  cmd->callback([o] { generate(*o); });
}

}  // namespace cofusion::commands
