#pragma once

// Frames COLMAP's mapper left out of its model, posed afterwards by PnP
// against the model's points: a frame's verified matches to posed frames
// (COLMAP's database, whose features were extracted outside the dynamic
// masks, so no match lies on a moving object) name the 3D points its
// keypoints see. The mapper gives up on a frame after a few failed tries
// and never comes back to frames of its smaller models; a frame between
// posed neighbours usually sees enough of their points.

#include <filesystem>
#include <string>
#include <vector>

#include "colmap_ext/model.h"

namespace pano4d {

struct LeftOutOptions {
  // The inliers a pose needs, in number and as a share of the frame's
  // 2D-3D correspondences: the mapper's own relaxed thresholds for casual
  // video (colmap_commands.h's RelaxedMapperArgs), so that a frame is taken
  // here on the evidence the mapper would have taken it on.
  int min_inliers = 15;
  double min_inlier_ratio = 0.15;
  // RANSAC's reprojection threshold, pixels. Tighter than the mapper's
  // abs_pose_max_error (12 px), since no bundle adjustment follows.
  double max_error_px = 4.0;
};

struct LeftOutReport {
  int left_out = 0;                // database frames the model lacked
  std::vector<std::string> posed;  // of those, the names posed here
};

// Poses the database's frames that `model` lacks, as many as the evidence
// allows, in rounds (a frame posed in one round lends its points' matches
// to the next) until a round poses none. Each is added to `model` with all
// its keypoints as points2D and its inlier observations in the points'
// tracks; the model's points and other poses are left as they are. A model
// without points (rotation-only) gains nothing. Throws pano4d::Error naming
// the database when it cannot be read.
LeftOutReport RegisterLeftOutFrames(const std::filesystem::path& database,
                                    ColmapModel* model,
                                    const LeftOutOptions& options = {});

}  // namespace pano4d
