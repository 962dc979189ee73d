// pano4d expand: one panoramic expansion step on its own, from the Gaussians
// that `pano4d fit` left in its checkpoint (src/pipeline/expand.h).
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/workspace_lock.h"
#include "src/pipeline/expand.h"

namespace pano4d::cli {

void AddExpandCommand(CLI::App& app, Action* action) {
  struct Options {
    std::filesystem::path workspace;
    ExpandOptions expand;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "expand",
      "Run one panoramic expansion step on the fitted Gaussians: "
      "trajectories, warping, prior, panoramas (no refinement)");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (WS/pano4d/checkpoints/fit.ckpt from "
                  "`pano4d fit`)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--step", o->expand.step,
                  "The step e (angle e x alpha); default: the one after the "
                  "last that ran")
      ->check(Positive());
  AddExpansionOptions(sub, &o->expand.fit.expansion);
  AddExpansionProductOptions(sub, &o->expand.fit);
  sub->footer(
      "Takes the expansion options of `pano4d fit` (those of its schedule "
      "do not apply to one step). Writes "
      "WS/pano4d/expand/step_<e>/dir_<m>/{warped,mask,refined}/ and "
      "cameras.json, WS/pano4d/expand/trajectories.json and colmap/ (the "
      "step's cameras beside the training ones), steps.json, and "
      "WS/pano4d/panorama/.");
  sub->callback([action, o] {
    *action = [o] {
      const FolderLock lock = LockWorkspace(o->workspace);
      const ExpandSummary s = RunExpand(Workspace(o->workspace), o->expand);
      std::printf("%s", s.FullReport().c_str());
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
