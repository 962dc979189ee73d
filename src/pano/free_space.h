#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "src/pano/layout.h"
#include "src/render/rasterizer.h"

namespace pano4d {

// Free-space carving for the expansion. A view through which surfaces were
// seen: its camera and the z-depth of what it saw. A point that it sees in
// front of its surface, by more than kFreeSpaceTolerance (relative), would
// hang in front of that surface in novel views.
struct SeenDepth {
  RasterCamera camera;
  cv::Mat depth;  // CV_32FC1, conservative (MakeSeenDepth); 0 = unknown
  // CV_8UC1: 1 where the depth all around was observed (the frames, or a
  // warp of them), 0 where some of it is the prior's guess (M_e). Empty:
  // observed everywhere.
  cv::Mat observed;
  // A video frame's camera stood in empty space: points nearer to its
  // centre than this (world units; CameraClearance) are empty, in every
  // direction, unless a frame sees them on a surface. 0: no such ball.
  float clearance = 0.0f;
};

// The ball around a video frame's camera that is taken as empty:
// kCameraClearance x the nearest depth it saw (its 2nd percentile, robust
// to a few wrong pixels). Nothing stood nearer to the camera in front of
// it, and the operator held it there; what lies beside or behind it the
// frame does not show, so the ball is kept inside the nearest surface.
// Without it, the expansion fills what no frame saw (behind and below the
// cameras, where an orbiting view looks back across the scene) at the
// depth of the farthest warped content around the hole, which can place a
// sheet of Gaussians in the air beside the cameras' path: invisible to
// every frame, a fog over a novel view that stands there
// (docs/experiments/2026-12-02-varied-synthetic-scenes.md). 0 when the
// depth has no valid pixel.
float CameraClearance(const cv::Mat& depth);
constexpr float kCameraClearance = 0.7f;

// Relative depth margin in front of a seen surface that still counts as the
// surface (depth noise, Gaussians' extent).
constexpr float kFreeSpaceTolerance = 0.05f;

// A point that no frame saw and that more than kFreeSpaceVotes times as
// many expanded views see through (guessed depth included) as have it on
// their surface, is in empty space: the views agree that something else is
// there (free-space violations against support, as in depth-map fusion,
// Merrell et al. 2007). 4 removes the floaters that blurred covisible
// pixels and keeps most unseen content
// (docs/experiments/2026-11-23-free-space-carving.md).
constexpr int kFreeSpaceVotes = 4;

// The view's depth made conservative for the test: each pixel holds the
// nearest depth of its 3x3 neighbourhood, and a pixel next to an unknown one
// (0 or not finite) is unknown. A point by a depth edge then is not taken
// for one seen through because its centre landed a pixel off. `guessed`
// (CV_8UC1, non-zero = depth from a prior, not observed; empty: none) marks
// the guesses, spread the same way. Throws pano4d::Error when the depth is
// not CV_32FC1 of the camera's size, or `guessed` not CV_8UC1 of it.
SeenDepth MakeSeenDepth(const RasterCamera& camera, const cv::Mat& depth,
                        const cv::Mat& guessed = cv::Mat());

// What views know of a point.
enum class Sight {
  kUnseen,      // outside them all, or hidden behind their surfaces
  kUnknown,     // inside one of them where its depth is unknown
  kOnSurface,   // within kFreeSpaceTolerance of a surface one of them saw
  kSeenThrough  // in front of a surface one of them saw
};
// One view; `observed` (optional) tells whether that depth was observed.
Sight LookFrom(const SeenDepth& view, const Eigen::Vector3f& point,
               bool* observed = nullptr);
// Any view that sees through it decides, then any that has it on its
// surface, then any that does not know.
Sight Look(const std::vector<SeenDepth>& views, const Eigen::Vector3f& point);

// Which of `count` points (xyz rows) lie in known empty space (parallel;
// 1 = empty):
// - seen through by a video frame (`frames`: what the video observed);
// - else, when no frame has it on its surface: inside a frame's clearance
//   ball;
// - else, when no frame saw it (a frame that has it on its surface keeps
//   it: an expanded view shows one frame's content, none of what other
//   frames saw; so does a frame without depth there, as stereo leaves
//   holes): seen through by an expanded view where its depth is observed
//   (a warp), or by more than kFreeSpaceVotes times as many expanded views
//   as have it on their surface.
// With `planes`, a point on a fitted plane face of that layout (the floor,
// a wall: Layout::PlaneFaceAt within `plane_tolerance`) is empty only when
// a frame sees through it: a plane fitted through many seen points is
// stronger evidence than a camera's clearance ball (the floor below a
// camera lies in it, out of its view) or an expanded view, whose warped
// depth grazes the floor at a slant.
std::vector<std::uint8_t> InFreeSpace(const std::vector<SeenDepth>& frames,
                                      const std::vector<SeenDepth>& expanded,
                                      const float* xyz, std::size_t count,
                                      const Layout* planes = nullptr,
                                      float plane_tolerance = 0);

}  // namespace pano4d
