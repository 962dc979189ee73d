#pragma once

// The eval stage: DyCheck's metrics of renders against a dataset split
// (evaluation/evaluate.h), written beside the paper's numbers.

#include <filesystem>
#include <string>

#include "evaluation/evaluate.h"
#include "src/core/frames.h"
#include "src/core/workspace.h"

namespace pano4d {

struct EvalOptions {
  std::filesystem::path dataset;
  std::filesystem::path renders;        // <id>.png per frame of the split
  std::filesystem::path out;            // empty: <renders>/metrics
  std::filesystem::path lpips_weights;  // empty: LPIPS reads n/a
  std::string split = "val";
  int factor = kProtocolFactor;  // the dataset's resolution divisor
};

struct EvalSummary {
  EvaluationResult result;
  std::filesystem::path out;  // metrics.json, metrics.md, per_frame.csv
  std::string markdown;       // the table beside the paper's rows
};

EvalSummary RunEval(const EvalOptions& options);

// Where the paper's numbers are (datasets_meta/): $PANO4D_DATASETS_META, or
// the source tree's folder.
std::filesystem::path DatasetsMetaDir();

// The validation split of a workspace's frames as a dataset to score: the
// dataset they came from (loaded again at their factor), or the workspace
// itself for frames held out of a video (kind kHeldOut).
Dataset ValidationDataset(const Workspace& workspace,
                          const WorkspaceFrames& frames);

}  // namespace pano4d
