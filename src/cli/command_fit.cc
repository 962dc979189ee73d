// pano4d fit: the fit controller (src/pipeline/fit.h) on a workspace's
// frames; prints its report.
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/log.h"
#include "src/core/workspace_lock.h"
#include "src/pipeline/fit.h"

namespace pano4d::cli {
namespace {

struct FitCommandOptions {
  std::filesystem::path workspace;
  FitOptions fit;
  bool force = false;
};

// The command: a workspace that holds a fit is refused without --resume or
// --force; with --force the previous fit is kept until the new one
// completes.
int RunFitCommand(const FitCommandOptions& o) {
  const FolderLock lock = LockWorkspace(o.workspace);
  const Workspace ws(o.workspace);
  RemoveLeftoverTemporaries(ws.root());
  // Bad options are refused before --force moves the previous fit aside.
  o.fit.Check();
  std::filesystem::path backup;
  if (!o.fit.resume && std::filesystem::exists(ws.checkpoint())) {
    if (!o.force) {
      throw Error::In(ws.checkpoint().string(),
                      "holds a fit already: --resume continues it, --force "
                      "starts again (keeping it in " +
                          ws.previous_fit().string() +
                          " until the new fit completes)");
    }
    backup = BackUpPreviousFit(ws);
    PANO4D_LOG(kInfo) << "fit: --force: the previous fit is kept in "
                      << backup.string() << " until this one completes";
  }
  FitSummary s;
  try {
    s = RunFit(ws, o.fit);
  } catch (...) {
    if (!backup.empty()) {
      PANO4D_LOG(kError) << "fit: the previous fit is kept in "
                         << backup.string();
    }
    throw;
  }
  if (s.termination == FitTermination::kStopped && StopRequested()) {
    // Stopped by the signal before its end: the previous fit's backup
    // stays (RunFit writes no fit.json), and exit 75 says "run again".
    std::printf("%s", s.FullReport().c_str());
    std::printf(
        "pano4d fit: stopped on request at iteration %lld; the checkpoint "
        "%s continues with `pano4d fit --workspace %s --resume`\n",
        static_cast<long long>(s.iterations), ws.checkpoint().c_str(),
        o.workspace.c_str());
    return kExitStopped;
  }
  if (!backup.empty()) std::filesystem::remove_all(backup);
  std::printf("%s", s.FullReport().c_str());
  return kExitOk;
}

}  // namespace

void AddFitCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<FitCommandOptions>();
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
  sub->add_flag("--force", o->force,
                "Start again on a workspace that holds a fit: the previous "
                "one is kept in WS/pano4d/previous_fit until the new one "
                "completes (without --force or --resume such a workspace is "
                "refused)")
      ->excludes("--resume");
  AddFitOptions(sub, &o->fit);
  AddPriorsOptions(sub, &o->fit.priors);
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
  sub->callback([action, o] { *action = [o] { return RunFitCommand(*o); }; });
}

}  // namespace pano4d::cli
