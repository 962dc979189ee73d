// pano4d sfm: camera poses and sparse points with COLMAP, and their
// comparison with a dataset's ground-truth cameras (src/pipeline/sfm.h).
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/workspace_lock.h"
#include "src/pipeline/sfm.h"

namespace pano4d::cli {

void AddSfmCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<SfmStageOptions>();
  SfmOptions* sfm = &o->sfm;
  CLI::App* sub = app.add_subcommand(
      "sfm",
      "Camera poses and sparse points with COLMAP (feature_extractor, "
      "matcher, mapper, image_undistorter), from a video or a folder of "
      "images, with moving objects masked out");
  AddFramesInputOptions(sub, &sfm->video, &sfm->images);
  AddDatasetOption(sub, &o->dataset);
  AddFactorOption(sub, &o->factor);
  sub->add_option("--workspace", sfm->workspace,
                  "COLMAP workspace (created): images/, masks/, database.db, "
                  "sparse/0, pano4d/")
      ->required();
  sub->add_option("--camera-model", sfm->camera_model,
                  "COLMAP camera model (SIMPLE_RADIAL, OPENCV, PINHOLE, ...)")
      ->capture_default_str();
  sub->add_option("--matcher", sfm->matcher,
                  "sequential (default for a video) or exhaustive (default "
                  "for images)")
      ->check(CLI::IsMember({"sequential", "exhaustive"}));
  sub->add_option("--stride", sfm->stride, "Keep every N-th frame")
      ->capture_default_str();
  sub->add_option("--max-frames", sfm->max_frames,
                  "Keep at most N frames (0: all)")
      ->capture_default_str();
  AddMaxSizeOption(sub, &sfm->max_size);
  sub->add_flag(
      "--no-dynamic-masks", [sfm](std::int64_t) { sfm->dynamic_masks = false; },
      "Do not mask moving objects out of feature extraction");
  sub->add_flag(
      "--camera-per-image", [sfm](std::int64_t) { sfm->single_camera = false; },
      "One camera per image instead of one shared camera");
  sub->add_flag("--force", sfm->force,
                "Redo every step, even those complete from an earlier run");
  sub->add_option("--colmap", sfm->colmap,
                  "The colmap executable (default: colmap on PATH)");
  sub->add_option("--compare-gt", o->compare_gt,
                  "A dataset (DyCheck layout, e.g. from `pano4d synth`) whose "
                  "cameras to compare with: ATE and RPE after Sim(3) "
                  "alignment, also in pano4d/metrics/sfm_ground_truth.json")
      ->check(CLI::ExistingDirectory);
  sub->footer(
      "With --dataset the training frames keep their cameras (at --factor) "
      "and colmap point_triangulator adds the sparse points. Each step is "
      "skipped when "
      "an earlier run completed it with the same "
      "inputs (logs and stamps in WS/pano4d/logs/, step times in "
      "timings.json); --force redoes all.");
  sub->callback([action, o] {
    *action = [o] {
      const FolderLock lock = LockWorkspace(o->sfm.workspace);
      std::printf("%s", RunSfmStage(*o).FullReport().c_str());
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
