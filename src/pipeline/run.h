#pragma once

// `pano4d run` and `demo` as a controller: the planner decides which stages
// an input needs (planner.h), and each stage runs through its own
// controller (sfm.h, depth.h, fit.h, eval.h), resuming what an earlier run
// left in the workspace; the report folder comes last (report.h).

#include <filesystem>
#include <iosfwd>

#include <nlohmann/json.hpp>

#include "colmap_ext/sfm.h"
#include "src/core/workspace.h"
#include "src/pipeline/depth.h"
#include "src/pipeline/fit_options.h"
#include "src/pipeline/planner.h"
#include "src/pipeline/report.h"

namespace pano4d {

struct RunOptions {
  // The input: exactly one of sfm.video, sfm.images, colmap, dataset.
  std::filesystem::path colmap, dataset;
  std::filesystem::path workspace;  // with colmap: empty or the same folder
  bool eval = false;  // DyCheck metrics when the input has ground truth
  std::filesystem::path lpips_weights;  // for eval; empty: LPIPS reads n/a
  // The stages' own options, as their commands take them: sfm (video,
  // images, max_size; its workspace is run's), depth (factor, holdout; its
  // dataset is run's) and the fit, whose init.num_bases = 0 and expand =
  // false are the user's word (the plan may leave motion or expansion out
  // as well).
  SfmOptions sfm;
  // After sfm, the run stops with the diagnosis when fewer than this share
  // of the frames are posed (0: fit whatever was posed).
  double min_posed = kDefaultMinPosed;
  DepthOptions depth;
  FitOptions fit;
  nlohmann::json ToJson() const;  // plan.json's "options"
};

struct RunSummary {
  Plan plan;
  nlohmann::json stages;  // per stage: status and seconds
  double seconds = 0.0;
  ReportSummary report;  // WS/report, written last
  std::string BriefReport() const;
};

// The facts the plan is made from, gathered from the input (and from the
// workspace, when an earlier run got past depth).
PlanFacts GatherFacts(const RunOptions& options);

// Plans, writes the plan table to `progress` (when given) and
// WS/pano4d/plan.json, and runs the stages. Throws pano4d::Error naming the
// input, before any work when the plan cannot be run, and after sfm when
// it posed fewer than min_posed of the frames (naming the share, the cause
// and what to try; plan.json records the sfm stage as "too few frames
// posed").
RunSummary RunPipeline(const RunOptions& options,
                       std::ostream* progress = nullptr);

}  // namespace pano4d
