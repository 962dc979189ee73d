// pano4d run: the planned pipeline on a video, images, a COLMAP workspace or
// a dataset (src/pipeline/run.h).
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/workspace_lock.h"
#include "src/pipeline/run.h"

namespace pano4d::cli {

void AddRunCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* sub = app.add_subcommand(
      "run",
      "Plan and run every stage on a video, images, COLMAP workspace or "
      "dataset: the plan says which stages run, which are left out and why");
  auto* input = sub->add_option_group("input", "exactly one of");
  AddFramesInputOptions(input, &o->sfm.video, &o->sfm.images);
  input
      ->add_option("--colmap", o->colmap,
                   "A COLMAP workspace with a model (poses given); it is "
                   "also the workspace unless --workspace says otherwise")
      ->check(CLI::ExistingDirectory);
  AddDatasetOption(input, &o->dataset);
  input->require_option(1);
  sub->add_option("--workspace", o->workspace, "The workspace (created)");
  sub->add_flag("--eval", o->eval,
                "Evaluate the validation renders (DyCheck metrics) when the "
                "input has ground truth");
  AddLpipsWeightsOption(sub, &o->lpips_weights);
  AddFactorOption(sub, &o->depth.factor);
  AddHoldoutOption(sub, &o->depth.holdout);
  AddDepthDirOption(sub, &o->depth.depth_dir);
  AddPriorsOptions(sub, &o->depth.priors, &o->depth);
  AddMaxSizeOption(sub, &o->sfm.max_size);
  sub->add_option("--min-posed", o->min_posed,
                  "Stop after sfm when COLMAP poses fewer than this share of "
                  "the frames, with the cause it found and what to try (0: "
                  "fit whatever was posed)")
      ->capture_default_str()
      ->check(InRange(0.0, 1.0));
  AddFitOptions(sub, &o->fit);
  sub->footer(
      "Writes WS/pano4d/plan.json (the plan, the facts it was made from, and "
      "per stage its status and seconds), what each stage writes (see "
      "`pano4d sfm|depth|fit|eval --help`), and WS/report/index.md (as "
      "`pano4d demo`). Run it again to resume; a fit with other options "
      "starts again.");
  sub->callback([action, o] {
    *action = [o] {
      const FolderLock lock = LockWorkspace(o->workspace);
      RunPipeline(*o, &std::cout);
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
