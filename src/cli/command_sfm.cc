// pano4d sfm: camera poses and sparse points with COLMAP (colmap_ext/sfm.h),
// and their comparison with a dataset's ground-truth cameras.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "colmap_ext/alignment.h"
#include "colmap_ext/model.h"
#include "colmap_ext/sfm.h"
#include "evaluation/dataset.h"
#include "src/cli/app.h"
#include "src/cli/stages.h"
#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

void CompareWithDataset(const fs::path& model_dir, const fs::path& root,
                        const fs::path& out_json) {
  const ColmapModel model = ReadModel(model_dir);
  const Dataset dataset = LoadDataset(root);
  std::vector<Rigid3d> estimate, reference;
  // `pano4d sfm` names every frame <stem>.png.
  for (const auto* split : {&dataset.train, &dataset.val}) {
    for (const DatasetFrame& frame : *split) {
      if (const ColmapImage* image = model.FindImageByName(frame.id + ".png")) {
        estimate.push_back(image->CamFromWorld(model_dir.string()));
        reference.push_back(frame.camera.cam_from_world);
      }
    }
  }
  if (estimate.size() < 3) {
    throw Error(root.string(), "frames", std::to_string(estimate.size()),
                "fewer than 3 registered images match a dataset frame id "
                "(image names must be <frame id>.png, as `pano4d sfm "
                "--images <dataset>/rgb/1x` writes them)");
  }
  const TrajectoryErrors e = CompareTrajectories(estimate, reference);
  std::vector<Eigen::Vector3d> points;
  for (const ColmapPoint3D& p : model.points3D)
    points.push_back(e.reference_from_estimate * p.xyz);
  const double extent = RobustExtent(points);
  std::printf(
      "  against %s: %d cameras matched, Sim(3) scale %.4g\n"
      "  ATE (camera centres): rmse %.4g, mean %.4g, median %.4g, max %.4g "
      "(scene extent %.4g, the sparse points' middle-90%% box: rmse = "
      "%.3f%%)\n"
      "  RPE (consecutive): translation rmse %.4g, rotation rmse %.4g deg\n",
      root.c_str(), e.cameras, e.reference_from_estimate.scale, e.ate_rmse,
      e.ate_mean, e.ate_median, e.ate_max, extent,
      extent > 0 ? 100 * e.ate_rmse / extent : 0.0, e.rpe_translation_rmse,
      e.rpe_rotation_rmse_deg);
  const nlohmann::json j = {
      {"dataset", fs::absolute(root).string()},
      {"cameras", e.cameras},
      {"scale", e.reference_from_estimate.scale},
      {"ate_rmse", e.ate_rmse},
      {"ate_mean", e.ate_mean},
      {"ate_median", e.ate_median},
      {"ate_max", e.ate_max},
      {"scene_extent", extent},
      {"ate_rmse_fraction_of_extent", extent > 0 ? e.ate_rmse / extent : 0.0},
      {"rpe_translation_rmse", e.rpe_translation_rmse},
      {"rpe_rotation_rmse_deg", e.rpe_rotation_rmse_deg}};
  WriteFileAtomically(out_json, j.dump(2) + "\n");
}

}  // namespace

int RunSfmCommand(SfmCommandOptions options) {
  options.sfm.dynamic_masks = !options.no_dynamic_masks;
  options.sfm.single_camera = !options.camera_per_image;
  if (!options.dataset.empty()) {
    // Known poses: the training frames at full resolution, named by id.
    const Dataset dataset = LoadDataset(options.dataset, /*factor=*/1);
    for (const DatasetFrame& frame : dataset.train)
      options.sfm.known.push_back({frame.rgb, frame.id + ".png", frame.camera});
  }
  const SfmReport r = RunSfm(options.sfm);
  std::printf(
      "pano4d sfm: %d of %d frames registered (%.1f%%), %d points, mean "
      "reprojection error %.3f px, %d model(s)\n"
      "  model: %s\n  images: %s\n",
      r.registered, r.frames, 100.0 * r.registered / std::max(1, r.frames),
      r.points3D, r.mean_reprojection_error, r.models, r.model.c_str(),
      r.images.c_str());
  for (const SfmStepReport& s : r.steps) {
    std::printf("  %-20s %8.1f s%s\n", s.step.c_str(), s.seconds,
                s.skipped ? "  (complete from an earlier run)" : "");
  }
  if (!options.compare_gt.empty()) {
    CompareWithDataset(
        r.model, options.compare_gt,
        options.sfm.workspace / "pano4d" / "metrics" / "sfm_ground_truth.json");
  }
  return kExitOk;
}

void AddSfmCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<SfmCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "sfm",
      "Camera poses and sparse points with COLMAP (feature_extractor, "
      "matcher, mapper, image_undistorter), from a video or a folder of "
      "images, with moving objects masked out");
  sub->add_option("--video", o->sfm.video, "Input video file")
      ->check(CLI::ExistingFile);
  sub->add_option("--images", o->sfm.images, "Input folder of .png/.jpg images")
      ->check(CLI::ExistingDirectory);
  sub->add_option("--dataset", o->dataset,
                  "A dataset with known cameras (DyCheck, Nvidia, Kubric-4D "
                  "layouts): its training frames keep their poses and colmap "
                  "point_triangulator adds sparse points")
      ->check(CLI::ExistingDirectory);
  sub->add_option("--workspace", o->sfm.workspace,
                  "COLMAP workspace (created): images/, masks/, database.db, "
                  "sparse/0, pano4d/")
      ->required();
  sub->add_option("--camera-model", o->sfm.camera_model,
                  "COLMAP camera model (SIMPLE_RADIAL, OPENCV, PINHOLE, ...)")
      ->capture_default_str();
  sub->add_option("--matcher", o->sfm.matcher,
                  "sequential (default for a video) or exhaustive (default "
                  "for images)")
      ->check(CLI::IsMember({"sequential", "exhaustive"}));
  sub->add_option("--stride", o->sfm.stride, "Keep every N-th frame")
      ->capture_default_str();
  sub->add_option("--max-frames", o->sfm.max_frames,
                  "Keep at most N frames (0: all)")
      ->capture_default_str();
  sub->add_option("--max-size", o->sfm.max_size,
                  "Resize so the longest side is at most PX (0: as is)")
      ->capture_default_str();
  sub->add_flag("--no-dynamic-masks", o->no_dynamic_masks,
                "Do not mask moving objects out of feature extraction");
  sub->add_flag("--camera-per-image", o->camera_per_image,
                "One camera per image instead of one shared camera");
  sub->add_flag("--force", o->sfm.force,
                "Redo every step, even those complete from an earlier run");
  sub->add_option("--colmap", o->sfm.colmap,
                  "The colmap executable (default: colmap on PATH)");
  sub->add_option("--compare-gt", o->compare_gt,
                  "A dataset (DyCheck layout, e.g. from `pano4d synth`) whose "
                  "cameras to compare with: ATE and RPE after Sim(3) "
                  "alignment, also in pano4d/metrics/sfm_ground_truth.json")
      ->check(CLI::ExistingDirectory);
  sub->footer(
      "Each step is skipped when an earlier run completed it with the same "
      "inputs (logs and stamps in WS/pano4d/logs/, step times in "
      "timings.json); --force redoes all.");
  sub->callback([action, o] { *action = [o] { return RunSfmCommand(*o); }; });
}

}  // namespace pano4d::cli
