// pano4d depth: the frames later stages work on, with depth and dynamic
// masks (src/pipeline/depth.h).
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/file.h"
#include "src/core/workspace_lock.h"
#include "src/pipeline/depth.h"

namespace pano4d::cli {

void AddDepthCommand(CLI::App& app, Action* action) {
  struct Options {
    std::filesystem::path workspace;
    DepthOptions depth;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "depth",
      "Per-frame z-depth and dynamic masks for fitting: external depth maps "
      "aligned to the SfM points (--depth-dir), a dataset's own depth, or "
      "plane-sweep stereo on the COLMAP poses (a dataset's cameras after "
      "`pano4d sfm --dataset`); writes WS/pano4d/frames.json");
  sub->add_option("--workspace", o->workspace, "The workspace (created)")
      ->required();
  AddDatasetOption(sub, &o->depth.dataset);
  AddFactorOption(sub, &o->depth.factor);
  AddDepthDirOption(sub, &o->depth.depth_dir);
  AddPriorsOptions(sub, &o->depth.priors, &o->depth);
  AddHoldoutOption(sub, &o->depth.holdout);
  sub->footer(
      "Writes WS/pano4d/frames.json, WS/pano4d/depth/<frame>.npy (z-depth, "
      "0 = none) with stereo.json or alignment.json, and dynamic masks in "
      "WS/pano4d/tracks/.");
  sub->callback([action, o] {
    *action = [o] {
      const FolderLock lock = LockWorkspace(o->workspace);
      const Workspace ws(o->workspace);
      RemoveLeftoverTemporaries(ws.root());
      const DepthSummary s = RunDepth(ws, o->depth);
      std::printf("pano4d depth: %s\n  frames: %s\n", s.BriefReport().c_str(),
                  ws.frames_json().c_str());
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
