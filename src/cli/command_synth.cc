// pano4d synth: a synthetic dynamic scene with exact ground truth, written in
// the DyCheck iPhone layout.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "evaluation/synth_generate.h"
#include "src/cli/app.h"
#include "src/cli/stages.h"
#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/timer.h"

namespace pano4d::cli {
int RunSynth(const SynthCommandOptions& options) {
  Timer timer;
  const synth::SynthSummary s =
      synth::GenerateSynthScene(options.synth, options.out);
  std::printf(
      "pano4d synth: %s (%dx%d at 1x, %d training frames, 2 x %d validation "
      "frames), seed %u%s\n"
      "  written to %s in %.1f s (render %.1f s, covisibility %.1f s, write "
      "%.1f s)\n"
      "  unseen fraction of validation pixels (2x): %.1f%% (covisible: seen in "
      "more than %d "
      "training views)\n",
      s.preset.name.c_str(), s.preset.width, s.preset.height,
      s.preset.train_frames, s.preset.val_frames, s.seed,
      s.is_static ? ", static" : "", options.out.c_str(), timer.WallSeconds(),
      s.render_seconds, s.covisibility_seconds, s.write_seconds,
      100.0 * s.unseen_fraction, s.covisibility_threshold);
  return kExitOk;
}

void EnsureSynthScene(const SynthCommandOptions& o) {
  const std::filesystem::path json =
      std::filesystem::path(o.out) / "synth.json";
  if (!std::filesystem::exists(json)) {
    RunSynth(o);
    return;
  }
  const Json j = ReadJson(json);
  const std::string preset = GetJson<std::string>(j, "preset", json.string());
  const int seed = GetJson<int>(j, "seed", json.string());
  const bool is_static = GetJsonOr<bool>(j, "static", false, json.string());
  if (preset != o.synth.preset || seed != static_cast<int>(o.synth.seed) ||
      is_static != o.synth.is_static) {
    throw Error(json.string(), "preset/seed",
                preset + " seed " + std::to_string(seed),
                "an earlier run made another scene here; use another "
                "--workspace or remove " +
                    o.out);
  }
  std::printf("pano4d: the synthetic scene in %s is from an earlier run\n",
              o.out.c_str());
}

void AddSynthCommand(CLI::App& app, Action* action) {
  auto options = std::make_shared<SynthCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "synth",
      "Generate a synthetic dynamic scene with exact ground truth (RGB, depth, "
      "instance and "
      "dynamic masks, covisible masks) in the DyCheck iPhone layout");
  sub->add_option(
         "--preset", options->synth.preset,
         "tiny: 128x96, 8 frames (tests); small: 480x360, 48 frames (demo); "
         "medium: 960x720, 120 frames (benchmarks)")
      ->check(CLI::IsMember({"tiny", "small", "medium"}))
      ->capture_default_str();
  sub->add_option("--seed", options->synth.seed,
                  "Scene variation; same seed, same bytes")
      ->capture_default_str();
  sub->add_option("--out", options->out,
                  "Output folder (created; files in it are replaced)")
      ->required();
  sub->add_flag("--static", options->synth.is_static,
                "Nothing moves (no dynamic objects)");
  sub->add_option("--dynamic-scale", options->synth.dynamic_scale,
                  "Scale of the moving objects: > 1 makes them cover more "
                  "of the frame (e.g. 2.5 to test SfM's dynamic masks)")
      ->check(CLI::Range(0.1, 10.0))
      ->capture_default_str();
  sub->callback([action, options] {
    *action = [options] { return RunSynth(*options); };
  });
}

}  // namespace pano4d::cli
