#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "src/core/posed_camera.h"

namespace pano4d {

// Multi-view depth on the CPU by plane sweep: for fronto-parallel planes of
// the reference camera, uniformly spaced in inverse depth, each neighbour
// frame is warped into the reference by the plane's homography
// (cv::warpPerspective) and compared by zero-mean normalised
// cross-correlation over a window (box filters); a pixel takes the plane of
// least cost, refined to sub-plane precision by a parabola. With several
// neighbours the cost is the mean of the best half, so that a pixel occluded
// in one neighbour is still matched in the others.
struct PlaneSweepOptions {
  int planes = 64;
  int window = 7;  // ZNCC window, pixels (odd)
  // A pixel is kept when its best ZNCC is at least this, ...
  double min_correlation = 0.6;
  // ... its window's grey standard deviation is at least this (texture,
  // grey in [0, 1]), and its best plane is not at either end of the range.
  double min_texture = 0.01;
  void Check() const;  // throws pano4d::Error naming the field
};

struct StereoView {
  cv::Mat grey;        // CV_32F in [0, 1]
  PosedCamera camera;  // pinhole, at the grey image's size
};

// The z-depth map of `reference` (CV_32F, 0 = no depth) between near and
// far (> 0), from `neighbours` (at least one). Throws pano4d::Error for
// non-pinhole cameras, sizes that disagree with them, or a bad range.
cv::Mat PlaneSweepDepth(const StereoView& reference,
                        const std::vector<StereoView>& neighbours, double near,
                        double far, const PlaneSweepOptions& options = {});

}  // namespace pano4d
