// pano4d fit: the fit controller (src/pipeline/fit.h) on a workspace's
// frames; prints its report.
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/pipeline/fit.h"

namespace pano4d::cli {

void AddFitCommand(CLI::App& app, Action* action) {
  struct Options {
    std::filesystem::path workspace;
    FitOptions fit;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "fit",
      "Fit the dynamic 4D Gaussians to the frames of `pano4d depth` (CPU "
      "rasterizer, Adam, densification), with panoramic expansion, "
      "validation, a run log and checkpoints");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (WS/pano4d/frames.json from `pano4d depth`)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_flag("--resume", o->fit.resume,
                "Continue from WS/pano4d/checkpoints/fit.ckpt (the same "
                "options required: a changed one is refused by name); "
                "without one, start from the beginning");
  AddFitOptions(sub, &o->fit);
  sub->footer(
      "Writes WS/pano4d/checkpoints/fit.ckpt, WS/pano4d/fit.json (summary: "
      "every option given and used, what ran, how long, why it stopped), "
      "WS/pano4d/metrics/fit.csv and fit.png (error against run time), and "
      "with validation frames WS/pano4d/renders/val/ (and z-depth in "
      "renders/val_depth/<frame>.npy) and WS/pano4d/metrics/metrics.json "
      "(keys psnr, ssim, mpsnr, mssim, upsnr, ussim, ...). With expansion: "
      "WS/pano4d/expansion/ (per step and direction the warped frames, "
      "masks M_e, refined frames; trajectories.json; colmap/ with the "
      "training and expanded cameras) and WS/pano4d/panorama/ (one "
      "equirectangular PNG per time step and static.png).");
  sub->callback([action, o] {
    *action = [o] {
      const FitSummary s = RunFit(Workspace(o->workspace), o->fit);
      std::printf("%s", s.FullReport().c_str());
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
