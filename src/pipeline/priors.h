#pragma once

// What the stages take from a learned priors folder (--priors,
// src/datasets/priors.h): the video its files name, and for the fit the
// flow and disparity of each training view. The depth stage's use (aligned
// depth, masks) is in depth.cc.

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/core/frames.h"
#include "src/core/workspace.h"
#include "src/datasets/priors.h"
#include "src/geometry/tracks.h"
#include "src/gs/training_view.h"

namespace pano4d {

// The video the priors were computed on, in time order, at the run's
// resolution: a dataset's training frames (its own cameras' video); for a
// COLMAP workspace every frame `pano4d sfm` wrote to WS/images, in the
// order it numbered them (NaturalLess), those the run does not fit (held
// out, or left unposed) marked unused.
std::vector<PriorFrame> PriorVideoFrames(const Workspace& workspace,
                                         const WorkspaceFrames& frames);

// The priors' flow between neighbouring training views and their
// disparity, attached to `views` (the training views of `frames`, in its
// order). Returns what was attached, for fit.json and the log: per kind
// the layout used, the frames or pairs without, and what was found and
// not used.
// The priors' tracks, when it holds some, go into `tracks` (over the
// frames' times, for the motion's initialisation) and, between training
// views kTrackFlowGaps apart that have no dense flow, into sparse flows
// (valid at the tracks' pixels) for the flow loss.
inline constexpr int kTrackFlowGaps[] = {1, 2};
nlohmann::json AttachPriors(const PriorsFolder& folder,
                            const std::vector<PriorFrame>& video,
                            const WorkspaceFrames& frames,
                            std::vector<TrainingView>* views,
                            Tracks2D* tracks = nullptr);

// One line per layout of `folder` and what the run does with it, for the
// plan and `pano4d dataset info`: "flow: OmniMotion raft_exhaustive/ (22
// files): the motion's initial tracks ...". `depth_instead` names the
// depth a run takes in place of the priors' ("the dataset's depth maps",
// "--depth-dir"); empty: the priors' depth is used.
std::vector<std::string> DescribePriorUse(const PriorsFolder& folder,
                                          const std::string& depth_instead = {});

}  // namespace pano4d
