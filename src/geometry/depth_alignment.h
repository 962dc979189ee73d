#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace pano4d {

// A sparse SfM point as one camera sees it: its pixel (COLMAP convention,
// pixel centres at +0.5) and its depth along that camera's optical axis.
struct DepthSample {
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  double z = 0.0;
};

struct DepthAlignmentOptions {
  // Cauchy loss scale on the relative residual (s d + b - z) / z: samples
  // off by much more than this fraction of their depth (moving objects,
  // mismatched points) barely pull the fit.
  double robust_scale = 0.05;
  int min_samples = 10;  // fewer: no reliable fit
  int max_iterations = 50;
  void Check() const;  // throws pano4d::Error naming the field
};

struct DepthAlignment {
  double scale = 1.0;  // z ~ scale * depth + shift
  double shift = 0.0;
  int samples = 0;  // samples with a valid depth under them
  int inliers = 0;  // of those, within robust_scale relative error
  double median_relative_error = 0.0;
};

// The scale and shift that bring a depth map (CV_32F, 0 or non-finite =
// no depth; e.g. from stereo or a monocular network) onto the SfM depths of
// `samples`, by a robust least-squares fit (Ceres, Cauchy loss) started from
// the plain least-squares line. Throws pano4d::Error when fewer than
// min_samples samples fall on valid depth, or when the depth under them is
// (nearly) constant, which leaves the scale undetermined.
DepthAlignment AlignDepth(const cv::Mat& depth,
                          const std::vector<DepthSample>& samples,
                          const DepthAlignmentOptions& options = {});

}  // namespace pano4d
