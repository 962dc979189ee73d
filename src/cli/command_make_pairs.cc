// pano4d make-pairs: (V_cov, mask, V_src) training clips for a video prior,
// by double reprojection along random panoramic directions.
#include <algorithm>
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/frames.h"
#include "src/core/json.h"
#include "src/core/workspace_lock.h"
#include "src/gs/training_view.h"
#include "src/pano/pairs.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

struct MakePairsCommandOptions {
  fs::path workspace;
  fs::path out;
  PairOptions pairs;
};

int RunMakePairsCommand(const MakePairsCommandOptions& o) {
  const WorkspaceFrames frames = ReadWorkspaceFrames(o.workspace);
  const PairsReport report =
      MakeTrainingPairs(LoadTrainingViews(frames.train), o.pairs, o.out);
  WriteJson(o.out / "pairs.json", report.ToJson());
  std::printf(
      "pano4d make-pairs: %d clips of %d frames in %s (masked: %.1f%% of "
      "pixels)\n",
      report.clips, report.frames_per_clip, o.out.c_str(),
      100 * report.mask_fraction);
  return kExitOk;
}

}  // namespace

void AddMakePairsCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<MakePairsCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "make-pairs",
      "Training pairs for a video prior: a random panoramic direction per "
      "clip, double reprojection of the source frames with their depth");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (WS/pano4d/frames.json from `pano4d depth`)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--out", o->out, "Output folder")->required();
  sub->add_option("--clips", o->pairs.clips, "Clips to write")
      ->capture_default_str();
  sub->add_option("--frames", o->pairs.frames,
                  "Frames per clip (fewer when the video is shorter)")
      ->capture_default_str();
  sub->add_option("--elevation", o->pairs.elevation_degrees,
                  "Angle reached at the clip's last frame, degrees")
      ->capture_default_str();
  AddSeedOption(sub, &o->pairs.seed, "Seed of the random directions");
  sub->footer(
      "Writes OUT/clip_<k>/cov/, mask/ (255 = lost in the round trip, to "
      "generate), src/ and meta.json (directions, angles, cameras), and "
      "OUT/pairs.json.");
  sub->callback([action, o] {
    *action = [o] {
      const FolderLock lock =
          LockWorkspace(o->workspace, FolderLock::Mode::kShared);
      return RunMakePairsCommand(*o);
    };
  });
}

}  // namespace pano4d::cli
