// pano4d synth: a synthetic dynamic scene with exact ground truth, written in
// the DyCheck iPhone layout (src/datasets/synth_generate.h).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/timer.h"
#include "src/datasets/synth_generate.h"

namespace pano4d::cli {

void AddSynthCommand(CLI::App& app, Action* action) {
  struct Options {
    synth::SynthOptions synth;
    std::filesystem::path out;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "synth",
      "Generate a synthetic dynamic scene with exact ground truth (RGB, "
      "depth, instance and dynamic masks, covisible masks) in the DyCheck "
      "iPhone layout");
  AddPresetOption(sub, &o->synth.preset);
  AddSeedOption(sub, &o->synth.seed, "Scene variation; same seed, same bytes");
  sub->add_option("--out", o->out,
                  "Output folder (created; files in it are replaced)")
      ->required();
  sub->add_flag("--static", o->synth.is_static,
                "Nothing moves (no dynamic objects)");
  sub->add_option("--dynamic-scale", o->synth.dynamic_scale,
                  "Scale of the moving objects: > 1 makes them cover more "
                  "of the frame (e.g. 2.5 to test SfM's dynamic masks)")
      ->check(InRange(0.1, 10.0))
      ->capture_default_str();
  sub->add_flag("--varied", o->synth.varied,
                "Draw the camera layout from the seed (validation cameras "
                "40-85 degrees aside at 0.6-2.4 m, a 30-70 degree training "
                "arc), object sizes, texture scale and an object close to a "
                "validation camera: scenes the default settings were not "
                "tuned on");
  sub->add_flag("--priors", o->synth.priors,
                "Also write learned-like priors of the training frames at "
                "1x, as the tools write them: MiDaS-like disparity "
                "(disp/<frame>.npy: an unknown affine per frame, a smooth "
                "error of a few percent, blurred edges) and RAFT-like flow "
                "between neighbouring frames (raft_exhaustive/: sub-pixel "
                "noise, blurred motion boundaries); `--priors SCENE` reads "
                "them");
  sub->add_option_function<std::string>(
         "--trajectory",
         [o](const std::string& name) {
           o->synth.trajectory = synth::TrainingMotionFromName(name);
         },
         "How the training camera moves: arc (default), slow-arc (an "
         "eighth of the arc: little parallax), pan (a fixed centre, "
         "turning), static-camera, handheld-still (drift and tremor of about "
         "a pixel); the cases casual videos bring SfM and the masks")
      ->check(CLI::IsMember(
          {"arc", "slow-arc", "pan", "static-camera", "handheld-still"}));
  sub->callback([action, o] {
    *action = [o] {
      Timer timer;
      const synth::SynthSummary s = synth::GenerateSynthScene(o->synth, o->out);
      std::printf(
          "pano4d synth: %s (%dx%d at 1x, %d training frames, 2 x %d "
          "validation frames), seed %u%s%s\n"
          "  written to %s in %.1f s (render %.1f s, covisibility %.1f s, "
          "write %.1f s)\n"
          "  unseen fraction of validation pixels (2x): %.1f%% (covisible: "
          "seen in more than %d training views)\n",
          s.preset.name.c_str(), s.preset.width, s.preset.height,
          s.preset.train_frames, s.preset.val_frames, s.seed,
          s.is_static ? ", static" : "", s.varied ? ", varied" : "",
          o->out.c_str(), timer.WallSeconds(), s.render_seconds,
          s.covisibility_seconds, s.write_seconds, 100.0 * s.unseen_fraction,
          s.covisibility_threshold);
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
