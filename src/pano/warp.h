#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "src/render/gaussians.h"

namespace pano4d {

// The discontinuity criterion's guards (ForwardWarp below).
// A log-depth step per pixel below this is always one surface: a plane
// steps by about tan(angle from its normal) / f a pixel, so 0.05 is a
// surface at 87 degrees at f = 400 px (pano4d's 480-pixel frames); exact
// depth keeps its creases and grazing floors whole, and an object stands
// out from what is behind it once it is 5% nearer.
inline constexpr float kWarpMinJump = 0.05f;
// How far a step must stand out from its neighbours': of 10^6 steps of
// Gaussian per-pixel noise the largest is about 7.3 times their median,
// and a median over 49 edges reads 25% low one time in ten; a 480 x 270
// frame with 1-10% noise breaks no edge at 10 (8 broke 7-70).
inline constexpr float kWarpJumpFactor = 10.0f;
// The neighbourhood whose median step is the surface's own: 7 x 7 pixels
// (49 edges of each direction), wide enough that a boundary's own edges,
// blurred over up to three pixels as in rendered depth, stay a minority,
// narrow enough to follow a curved surface's slope.
inline constexpr int kWarpJumpWindow = 7;
// A triangle that the target sees this many times larger than a patch
// facing both cameras at its distances, amid triangles that mostly are too,
// is left out: a surface the source saw nearly edge-on (78 degrees, for a
// target that faces it) holds no detail for the target. On lady-running's
// rendered depth, whose soft Gaussian edges join objects into steep
// sheets, 10 still left long smears across the expanded views.
inline constexpr double kWarpMaxStretch = 5.0;
// The crack measure's default kernel: gaps of up to 4 pixels (a surface
// magnified up to 5x by a splat) count as cracks.
inline constexpr int kCrackKernel = 5;

// A frame forward-warped into another camera (DESIGN.md, "Warping").
struct WarpResult {
  cv::Mat rgb;    // CV_32FC3 RGB; 0 where mask is set
  cv::Mat depth;  // CV_32FC1 z-depth in the target camera; 0 where mask is set
  cv::Mat mask;   // CV_8UC1: 255 = no source surface reached the pixel (M_e)
};

// Mesh warp of a source frame into `target`. Every source pixel with depth
// > 0 (and `valid` set, when given: CV_8UC1, non-zero = warp) is a vertex at
// its centre, lifted with its z-depth; each 2x2 block of vertices gives two
// triangles (split along the diagonal whose depths agree better; one
// triangle when a corner is missing). Triangles are rasterised into the
// target with a z-buffer (the nearest surface wins), colour and depth
// interpolated barycentrically (perspective-correct: depth is the plane's
// through the three points), so a magnified surface stays whole. A pixel is
// a hole (M_e) only where no surface reaches it: out of the source's view,
// a disocclusion, or a surface the source saw edge-on.
//
// A triangle is dropped when one of its edges crosses a depth
// discontinuity: its log-depth step d = |ln z_a - ln z_b| exceeds both
// kWarpMinJump and kWarpJumpFactor x the median step of the same
// direction's edges in the kWarpJumpWindow^2 pixels around it. The floor
// keeps every surface of exact depth whole; the median is the local scale
// of one surface's steps (its slope along that direction, or the noise of
// real depth), so noise of a few percent per pixel breaks nothing while a
// step that stands out from its neighbours' is an occlusion boundary. A
// fixed band fails on real depth, whose steps across one surface exceed
// what some object edges step.
//
// A triangle is also dropped where the source saw the surface edge-on: the
// target sees it more than kWarpMaxStretch times larger than a patch at the
// same distances that faced both cameras (a camera that is only closer
// magnifies by the distance ratio and is not stretched), and so do most
// triangles of the 3 x 3 blocks around it. Measured in the target, not by
// the triangle's normal in the source: on noisy depth a pixel-sized
// triangle's normal is mostly noise (3% at f = 400 px tilts it by more than
// 80 degrees), while its stretch grows only with the baseline, and the vote
// of its neighbours outweighs a few drawn long by noise.
//
// Where the mesh ends at a break, a pixel without depth or the image's
// border, it stops at pixel centres; there each source pixel also covers
// its own footprint, the square it saw, at its depth, behind the triangles
// of its own surface (within kWarpMinJump) and in front of farther ones. A
// disocclusion is then as wide as the parallax, one-pixel structures
// survive, and a frame warped into its own camera comes back whole, with an
// empty mask. An edge-on surface gets no footprints: they would scatter
// over it as a lace. Throws pano4d::Error when sizes or types do not match
// the cameras. Pinhole cameras (RasterCamera) only. Keeps its working
// buffers (about 80 bytes a pixel) per thread between calls.
WarpResult ForwardWarp(const cv::Mat& rgb, const cv::Mat& depth,
                       const RasterCamera& source, const RasterCamera& target,
                       const cv::Mat& valid = cv::Mat());

// Chaining: fills the holes of `into` from `from` (the same target camera),
// keeping every pixel `into` already covers. Returns the count filled.
int FillHoles(const WarpResult& from, WarpResult* into);

// Cracks in a warp's M_e (`mask`: CV_8UC1, non-zero = hole): the hole pixels
// that a morphological closing of the covered pixels with a `kernel` x
// `kernel` square fills, i.e. holes narrower than `kernel` pixels with
// coverage on both sides. Cracks of a forward splat are such gaps (one or
// two pixels between the landings of one magnified surface); out-of-view
// regions and disocclusions of real parallax are wider and stay open
// (outside the image counts as uncovered, so a band along the border is not
// a crack). Disocclusions narrower than the kernel (small parallax at a
// small depth step) count as cracks: the measure is an upper bound.
std::int64_t CountCracks(const cv::Mat& mask, int kernel = kCrackKernel);
// CountCracks / the count of hole pixels; 0 for a mask without holes.
double CrackFraction(const cv::Mat& mask, int kernel = kCrackKernel);

}  // namespace pano4d
