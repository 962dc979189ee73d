#pragma once

// `pano4d run` and `demo` as a controller: the planner decides which stages
// an input needs (planner.h), and each stage runs through its own
// controller (sfm.h, depth.h, fit.h, eval.h), resuming what an earlier run
// left in the workspace; the report folder comes last (report.h).

#include <filesystem>
#include <iosfwd>

#include <nlohmann/json.hpp>

#include "src/core/workspace.h"
#include "src/pipeline/fit_options.h"
#include "src/pipeline/planner.h"
#include "src/pipeline/report.h"

namespace pano4d {

struct RunOptions {
  // The input: exactly one of these.
  std::filesystem::path video, images, colmap, dataset;
  std::filesystem::path workspace;  // with colmap: empty or the same folder
  bool eval = false;  // DyCheck metrics when the input has ground truth
  int factor = 2;     // a dataset's resolution divisor
  int holdout = 0;    // video/images: every N-th frame held out (0: none)
  int max_size = 0;   // video/images: longest side for SfM (0: as is)
  // The fit's options: init.num_bases = 0 and expand = false are the
  // user's word; the plan may leave motion or expansion out as well.
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
// input, before any work when the plan cannot be run.
RunSummary RunPipeline(const RunOptions& options,
                       std::ostream* progress = nullptr);

}  // namespace pano4d
