#pragma once

// Camera rotations and a shared focal length for a camera that turns about
// a fixed centre (a pan, or a camera on a tripod): between two such frames
// every match obeys x_j ~ K R_j R_i^T K^-1 x_i, a homography, with nothing
// to triangulate, so COLMAP's mapper cannot start. The estimate is the
// homographies' focal length and rotations, refined by a bundle adjustment
// of the rotations and focal length over the matches (Ceres).

#include <optional>
#include <vector>

#include <Eigen/Core>

namespace pano4d {

// Matched pixel positions of frames i and j (pixel centres at +0.5, as
// COLMAP's keypoints).
struct FrameMatches {
  int i = 0, j = 0;
  std::vector<Eigen::Vector2d> xi, xj;
};

struct RotationOnlyOptions {
  double ransac_pixels = 2.0;  // the homography's inlier threshold
  int min_inliers = 20;        // a pair with fewer is left out
  // Matches per pair in the bundle adjustment (a spread subsample): the
  // rotations are 3 numbers a frame, and more matches only cost time.
  int max_matches_per_pair = 150;
};

struct RotationOnlyEstimate {
  int width = 0, height = 0;
  double focal = 0.0;  // pixels, one for both axes; principal point centred
  // Per frame, rotation from the first posed frame's camera (the world) to
  // its camera; empty for a frame no pair connects to that one.
  std::vector<std::optional<Eigen::Matrix3d>> cam_from_world;
  int pairs = 0;          // pairs used
  double rms_pixels = 0;  // transfer error over the pairs' inliers
  int Posed() const;
};

// A camera that stands still (every homography moves the image corners by
// less than a pixel) gets identity rotations and COLMAP's prior focal
// length, 1.2 x the larger side (the focal length is unobservable then).
// Throws pano4d::Error when no pair has min_inliers homography inliers, or
// the focal length has no minimum in [0.25, 4] x the larger image side.
RotationOnlyEstimate EstimateRotationOnly(
    int frames, int width, int height, const std::vector<FrameMatches>& pairs,
    const RotationOnlyOptions& options = {});

}  // namespace pano4d
