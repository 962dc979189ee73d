#include "src/pipeline/sfm.h"

#include <algorithm>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "colmap_ext/model.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/strings.h"
#include "src/datasets/dataset.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

SfmComparison CompareWithDataset(const fs::path& model_dir,
                                 const fs::path& root) {
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
  SfmComparison c;
  c.dataset = root;
  c.errors = CompareTrajectories(estimate, reference);
  std::vector<Eigen::Vector3d> points;
  for (const ColmapPoint3D& p : model.points3D)
    points.push_back(c.errors.reference_from_estimate * p.xyz);
  c.scene_extent = RobustExtent(points);
  return c;
}

}  // namespace

std::string SfmComparison::BriefReport() const {
  const TrajectoryErrors& e = errors;
  const double extent = scene_extent;
  return StringPrintf(
      "against %s: %d cameras matched, Sim(3) scale %.4g\n"
      "  ATE (camera centres): rmse %.4g, mean %.4g, median %.4g, max %.4g "
      "(scene extent %.4g, the sparse points' middle-90%% box: rmse = "
      "%.3f%%)\n"
      "  RPE (consecutive): translation rmse %.4g, rotation rmse %.4g deg\n",
      dataset.c_str(), e.cameras, e.reference_from_estimate.scale, e.ate_rmse,
      e.ate_mean, e.ate_median, e.ate_max, extent,
      extent > 0 ? 100 * e.ate_rmse / extent : 0.0, e.rpe_translation_rmse,
      e.rpe_rotation_rmse_deg);
}

std::string SfmStageSummary::FullReport() const {
  const SfmReport& r = report;
  std::string s = StringPrintf(
      "pano4d sfm: %d of %d frames posed (%.1f%%), %d points, mean "
      "reprojection error %.3f px, %d model(s)\n",
      r.registered, r.frames, 100.0 * r.diagnosis.PosedFraction(), r.points3D,
      r.mean_reprojection_error, r.models);
  if (r.posed_by_pnp > 0) {
    s += StringPrintf(
        "  %d of them left out by the mapper and posed by PnP against its "
        "points\n",
        r.posed_by_pnp);
  }
  if (r.static_camera) {
    s += "  camera: static (one pose for every frame: the frames match by "
         "the identity; no points)\n";
  } else if (r.rotation_only) {
    s += "  camera: the rotation-only model (the frames match by "
         "homographies that rotations explain: one centre, no points)\n";
  }
  if (!r.diagnosis.AllPosed()) {
    s += "  not posed: " + r.diagnosis.Cause() +
         "\n  to pose more: " + r.diagnosis.Remedy() + "\n";
  }
  s += StringPrintf("  model: %s\n  images: %s\n", r.model.c_str(),
                    r.images.c_str());
  for (const SfmStepReport& step : r.steps) {
    s += StringPrintf("  %-20s %8.1f s%s\n", step.step.c_str(), step.seconds,
                      step.skipped ? "  (complete from an earlier run)" : "");
  }
  if (comparison) s += "  " + comparison->BriefReport();
  return s;
}

SfmStageSummary RunSfmStage(const SfmStageOptions& options) {
  SfmOptions sfm = options.sfm;
  if (!options.dataset.empty()) {
    // Known poses: the training frames at the stage's factor (the
    // resolution every later stage works at), named by id.
    const Dataset dataset = LoadDataset(options.dataset, options.factor);
    for (const DatasetFrame& frame : dataset.train)
      sfm.known.push_back({frame.rgb, frame.id + ".png", frame.camera});
  }
  SfmStageSummary summary;
  summary.report = RunSfm(sfm);
  if (!options.compare_gt.empty()) {
    summary.comparison =
        CompareWithDataset(summary.report.model, options.compare_gt);
    const TrajectoryErrors& e = summary.comparison->errors;
    const double extent = summary.comparison->scene_extent;
    const nlohmann::json j = {
        {"dataset", fs::absolute(options.compare_gt).string()},
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
    WriteFileAtomically(Workspace(sfm.workspace).sfm_ground_truth_json(),
                        j.dump(2) + "\n");
  }
  return summary;
}

}  // namespace pano4d
