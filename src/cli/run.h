#pragma once

// `pano4d run` as a function, for `pano4d demo` and the tests.

#include <filesystem>

#include <nlohmann/json.hpp>

#include "src/cli/planner.h"
#include "src/cli/report.h"
#include "src/cli/stages.h"

namespace pano4d::cli {

struct RunCommandOptions {
  // The input: exactly one of these.
  std::filesystem::path video, images, colmap, dataset;
  std::filesystem::path workspace;
  bool eval = false;
  int factor = 2;    // a dataset's resolution divisor
  int holdout = 0;   // video/images: every N-th frame held out (0: none)
  int max_size = 0;  // video/images: longest side for SfM (0: as is)
  // The fit's options (no_motion and no_expansion are the user's word; the
  // plan may leave more out).
  FitCommandOptions fit;
};

struct RunReport {
  Plan plan;
  nlohmann::json stages;  // per stage: status and seconds
  double seconds = 0.0;
  ReportSummary report;  // WS/report, written last
};

// The facts the plan is made from, gathered from the input (and from the
// workspace, when an earlier run got past depth).
PlanFacts GatherFacts(const RunCommandOptions& options);

// Plans, prints the plan, writes WS/pano4d/plan.json and runs the stages,
// each resuming what an earlier run left, then writes the report folder
// WS/report (report.h). Throws pano4d::Error.
int RunPipeline(const RunCommandOptions& options, RunReport* report);

}  // namespace pano4d::cli
