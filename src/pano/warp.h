#pragma once

#include <opencv2/core.hpp>

#include "src/render/gaussians.h"

namespace pano4d {

// A frame forward-warped into another camera (DESIGN.md, "Warping").
struct WarpResult {
  cv::Mat rgb;    // CV_32FC3 RGB; 0 where mask is set
  cv::Mat depth;  // CV_32FC1 z-depth in the target camera; 0 where mask is set
  cv::Mat mask;   // CV_8UC1: 255 = no source point reached the pixel (M_e)
};

// Z-buffered forward splat of a source frame into `target`: every source
// pixel with depth > 0 (and `valid` set, when given: CV_8UC1, non-zero =
// warp) is lifted with its z-depth and lands bilinearly on the 2x2 target
// pixels around its projection. Per target pixel the nearest surface wins:
// points within kWarpDepthTolerance (relative) of the nearest are averaged
// by weight, farther ones are hidden. A pixel that no point reaches with
// weight kWarpMinWeight is a hole, unless it is a crack: a gap of at most
// kWarpMaxCrack pixels between covered pixels of one surface (depths within
// the tolerance) along a row, column or diagonal, which magnification opens
// between the landings of neighbouring source pixels; cracks are filled by
// interpolation. Warping a frame into its own camera gives
// it back with an empty mask. Throws pano4d::Error when sizes or types do
// not match the cameras. Pinhole cameras (RasterCamera) only.
WarpResult ForwardWarp(const cv::Mat& rgb, const cv::Mat& depth,
                       const RasterCamera& source, const RasterCamera& target,
                       const cv::Mat& valid = cv::Mat());

// Chaining: fills the holes of `into` from `from` (the same target camera),
// keeping every pixel `into` already covers. Returns the count filled.
int FillHoles(const WarpResult& from, WarpResult* into);

// Relative depth band within which splats count as one surface: wider than
// the spread of one surface's points across a pixel at grazing angles,
// narrower than the gap between an object and what lies behind it.
inline constexpr float kWarpDepthTolerance = 0.02f;
// A bilinear share below this neither claims a pixel's depth nor covers it:
// a point's far corner would otherwise bleed foreground one pixel into the
// background.
inline constexpr float kWarpMinWeight = 0.1f;
// Cracks are bridged from at most this many pixels on either side (gaps of
// up to 3 pixels): a surface magnified up to about 4x (an expanded camera
// closer to it, or facing it where the source saw it obliquely) stays
// whole, while wider holes in one surface are left to the prior, and
// disocclusions, which lie between surfaces at different depths, are never
// bridged.
inline constexpr int kWarpMaxCrack = 2;

}  // namespace pano4d
