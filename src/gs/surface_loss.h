#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "src/render/gaussians.h"

namespace pano4d {

// Depth-normal flatness: Gaussians on a surface that a training view's
// depth map shows should be flat discs in that surface.
//
// Why: 3DGS's losses see a Gaussian only through its footprint in the
// training views. A video's cameras sweep a narrow arc, so a Gaussian may
// stretch along the training rays (a fin standing out of the surface)
// without changing any training image or the rendered depth (a Gaussian's
// depth is its centre's). Seen from 70 degrees aside, fins hang in front
// of the surfaces behind them and blur the textures. With depth maps the
// surface's normal n is known, and
//   f_i = n^T Sigma_i n / trace(Sigma_i)   (in [0, 1])
// is the share of the Gaussian's variance across the surface: 0 for a disc
// in the surface, 1 for a needle along the normal. It is scale-free, so
// small and large Gaussians count alike, and smooth in the log-scales and
// the quaternion (no choice of a "shortest axis").

// A depth map's normal is not taken across a depth edge: a neighbour more
// than this far off (relative) lies on another surface.
inline constexpr float kNormalEdgeJump = 0.05f;

// The unit normal of `depth` (H x W z-depth, 0 = none, of `camera`'s size)
// at pixel (x, y), in the camera frame: the cross product of the central
// differences of the unprojected 4-neighbours. False at the border, where
// a neighbour has no depth, or across a depth edge.
template <typename T>
bool DepthNormalAt(const std::vector<float>& depth,
                   const RasterCameraT<T>& camera, int x, int y,
                   Eigen::Matrix<T, 3, 1>* normal);

struct NormalFlatness {
  double loss = 0.0;           // weight x mean f_i over the Gaussians used
  std::int64_t gaussians = 0;  // Gaussians on a surface the depth map shows
};

// weight x the mean of f_i over the Gaussians whose centre projects onto a
// pixel of `depth` with a normal and lies within `tolerance` (relative) of
// that pixel's depth; the others (occluded, off the surface, outside the
// view) are left out. Adds dL/dlog_scales and dL/dquats to the N x 3 and
// N x 4 arrays (sized like the model). The mean's membership does not
// depend smoothly on the means, which get no gradient.
template <typename T>
NormalFlatness NormalFlatnessLoss(const GaussianModelT<T>& model,
                                  const RasterCameraT<T>& camera,
                                  const std::vector<float>& depth,
                                  double weight, double tolerance,
                                  std::vector<T>* d_log_scales,
                                  std::vector<T>* d_quats);

// Moving-object thickness: a dynamic Gaussian that a training view shows
// inside the moving object's silhouette, deeper behind the depth map's
// surface than the object can be thick, is hidden in that view and placed
// wrongly.
//
// Why: a moving object is seen from one camera at each time, and the
// photometric and depth losses see only its visible surface. The motion
// bases are shared, so at a given time some of the object's Gaussians land
// behind that surface, where nothing in the training view can see them;
// from a camera 70 degrees aside they stand beside the object, in front of
// the background, and make the covisible pixels render too near
// (docs/experiments/2026-11-22-hidden-depth-term.md).
struct HiddenDepth {
  double loss = 0.0;           // weight x mean hinge over the candidates
  std::int64_t gaussians = 0;  // candidates: rows >= first inside the mask
  std::int64_t hidden = 0;     // of which deeper than the thickness allows
};

// weight x the mean over the Gaussians of rows [first, N) whose centre
// projects onto a pixel of `mask` (nonzero = moving) with a depth d of
//   max(0, z / d - 1 - thickness),
// z the centre's camera depth; the others are left out. Adds dL/dmeans to
// the N x 3 array `d_means` (sized like the model). `depth` and `mask` are
// H x W of `camera`'s size; the pixel (hence d) is held fixed.
template <typename T>
HiddenDepth HiddenDepthLoss(const GaussianModelT<T>& model, std::size_t first,
                            const RasterCameraT<T>& camera,
                            const std::vector<float>& depth,
                            const std::vector<std::uint8_t>& mask,
                            double weight, double thickness,
                            std::vector<T>* d_means);

}  // namespace pano4d
