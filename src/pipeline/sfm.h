#pragma once

// The sfm stage: camera poses and sparse points with COLMAP
// (colmap_ext/sfm.h), from a video, a folder of images, or a dataset's
// frames with their known cameras; and their comparison with a dataset's
// ground-truth cameras.

#include <filesystem>
#include <optional>
#include <string>

#include "colmap_ext/alignment.h"
#include "colmap_ext/sfm.h"
#include "src/core/workspace.h"
#include "src/datasets/dataset.h"

namespace pano4d {

struct SfmStageOptions {
  SfmOptions sfm;  // its workspace is the stage's
  // A dataset whose training frames keep their cameras (at `factor`, named
  // <id>.png); colmap point_triangulator adds the sparse points.
  std::filesystem::path dataset;
  int factor = kProtocolFactor;  // the dataset's resolution divisor
  // A dataset whose cameras to compare the estimate with (ATE, RPE).
  std::filesystem::path compare_gt;
};

struct SfmComparison {
  std::filesystem::path dataset;
  TrajectoryErrors errors;
  double scene_extent = 0.0;  // RobustExtent of the aligned points
  std::string BriefReport() const;
};

struct SfmStageSummary {
  SfmReport report;
  std::optional<SfmComparison> comparison;  // with compare_gt
  std::string FullReport() const;
};

// Writes what RunSfm writes, and with compare_gt
// WS/pano4d/metrics/sfm_ground_truth.json.
SfmStageSummary RunSfmStage(const SfmStageOptions& options);

}  // namespace pano4d
