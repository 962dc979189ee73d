#pragma once

#include <vector>

#include <Eigen/Core>

#include "src/core/rigid.h"

namespace pano4d {

// The similarity that maps `source` points onto `target` points in the least
// squares sense (Umeyama 1991, with scale): target_i ~ T * source_i.
// Throws pano4d::Error when there are fewer than 3 pairs, the counts differ,
// a point is not finite, or the source points are (nearly) collinear, where
// the rotation about their line is undetermined.
Sim3d AlignPoints(const std::vector<Eigen::Vector3d>& source,
                  const std::vector<Eigen::Vector3d>& target);

// How far an estimated camera trajectory is from a reference one, after the
// Sim(3) alignment of the camera centres (monocular SfM fixes neither the
// scale nor the world frame). Distances are in reference units.
struct TrajectoryErrors {
  int cameras = 0;
  Sim3d reference_from_estimate;
  // Absolute trajectory error: |c_ref - T c_est| over the cameras.
  double ate_rmse = 0.0;
  double ate_mean = 0.0;
  double ate_median = 0.0;
  double ate_max = 0.0;
  // Relative pose error between consecutive cameras (i, i + 1): the
  // translation (reference units) and rotation (degrees) of
  // (ref_i^-1 ref_{i+1})^-1 (est_i^-1 est_{i+1}), est aligned; RMSE.
  double rpe_translation_rmse = 0.0;
  double rpe_rotation_rmse_deg = 0.0;
};

// Poses are cam_from_world, in the same order (pair i is the same frame);
// at least 3 cameras.
TrajectoryErrors CompareTrajectories(const std::vector<Rigid3d>& estimate,
                                     const std::vector<Rigid3d>& reference);

// The size of a point cloud, robust to the few far outliers SfM
// triangulates: the diagonal of the box holding the middle 90% of the points
// on each axis; 0 for fewer than 10 points.
double RobustExtent(const std::vector<Eigen::Vector3d>& points);

}  // namespace pano4d
