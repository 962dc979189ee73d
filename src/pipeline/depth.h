#pragma once

// The depth stage: the frames every later stage works on
// (WS/pano4d/frames.json), each with a z-depth map (WS/pano4d/depth/) and a
// dynamic mask, from a dataset with known cameras or from the COLMAP
// workspace of `pano4d sfm`. Depth comes from another tool's maps aligned to
// the SfM points when depth_dir is given (the user's word), else from the
// dataset when it has depth for every training frame, else from plane-sweep
// stereo on the COLMAP model's poses (for a dataset: its own cameras, with
// the points of `pano4d sfm --dataset` at the same factor).

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/core/frames.h"
#include "src/core/stamp.h"
#include "src/core/workspace.h"
#include "src/datasets/dataset.h"
#include "src/geometry/stereo.h"
#include "src/geometry/stereo_neighbours.h"

namespace pano4d {

struct DepthOptions {
  std::filesystem::path dataset;    // empty: the workspace's COLMAP model
  std::filesystem::path depth_dir;  // <frame>.npy/.png/.tiff/.exr; empty: none
  // Learned priors (src/datasets/priors.h; empty: none): their depth,
  // aligned to the SfM points per frame, gives the moving pixels and the
  // static pixels stereo leaves without depth their depth; their motion
  // masks replace the computed ones (or join them, prior_masks_join).
  std::filesystem::path priors;
  bool prior_masks_join = false;
  // The learned depth's local correction towards stereo: a Gaussian of
  // this fraction of the frame's width (CorrectDepthLocally); 0: the
  // affine per frame alone.
  double learned_depth_smoothing = 0.08;
  // Rescale each frame's moving pixels' learned depth so that, along the
  // priors' flow between neighbouring frames, their depth changes as much
  // as the flow stretches them (ConsistentMovingDepthScales); needs flow,
  // and without it each frame keeps its own alignment.
  bool consistent_moving_depth = true;
  int factor = kProtocolFactor;  // a dataset's resolution divisor
  int holdout = 0;  // COLMAP frames: every N-th (i % N == 0) validates
  // Stereo: frames are matched at most this many pixels on the long side
  // (time; the fit's frames are usually smaller).
  int stereo_long_side = 640;
  StereoNeighbourOptions neighbours;
  PlaneSweepOptions sweep;
  void Check() const;  // throws pano4d::Error naming the option
  nlohmann::json ToJson() const;
};

struct DepthSummary {
  WorkspaceFrames frames;  // as written to frames.json
  int with_depth = 0;      // training frames with a depth map
  // Training frames whose depth took learned depth, and those whose
  // learned depth could not be aligned (WS/pano4d/depth/priors.json says
  // why).
  int with_learned_depth = 0;
  std::vector<std::string> alignment_failed;
  std::vector<std::string> without_learned_depth;  // no file in the priors
  std::string BriefReport() const;
};

// Writes WS/pano4d/frames.json and the depth maps, and the stage's stamp
// (DepthStageRecord) once they are complete.
DepthSummary RunDepth(const Workspace& workspace, const DepthOptions& options);

// What the depth stage reads (its options; the dataset's files, or the SfM
// model, images and masks; --depth-dir) and writes, for its stamp:
// `pano4d run` reuses the stage while its stamp records the same.
StageRecord DepthStageRecord(const Workspace& workspace,
                             const DepthOptions& options);

// The depth source RunDepth takes (one of kDepthFrom*, frames.h): the order
// of preference above. The planner names it before any work.
const char* DepthSourceFor(bool dataset_depth,
                           const std::filesystem::path& depth_dir);

// Whether every training frame of the dataset has a depth map.
bool HasDepth(const Dataset& dataset);

// The depth map of each frame in `dir` (<name>.npy, .png, .tiff, .tif or
// .exr, in that order); throws pano4d::Error naming the folder and the
// first frame without one.
std::vector<std::filesystem::path> ExternalDepthFiles(
    const std::filesystem::path& dir, const std::vector<std::string>& frames);

}  // namespace pano4d
