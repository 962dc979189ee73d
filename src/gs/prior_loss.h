#pragma once

#include <cstdint>
#include <vector>

#include "src/render/gaussians.h"

namespace pano4d {

// Losses against learned priors (--priors): what holds a moving object
// together across times when one camera sees each time.

// Flow consistency, per Gaussian (the 2D displacement term of DynamicNeRF
// and Shape of Motion, on Gaussian centres): a dynamic Gaussian that frame
// a shows at pixel p, posed at frame b's time and seen by b's camera,
// should land where the flow from a to b carries p.
//
// Why: each time's moving pixels are fitted from its own camera only, so
// the photometric loss lets a Gaussian show one part of the object at one
// time and another part at the next; seen from any other camera the object
// becomes a cloud of streaks. The flow names which point of b is which
// point of a.
struct FlowTerm {
  double loss = 0.0;           // weight x mean Huber(|r|) / image width
  std::int64_t gaussians = 0;  // Gaussians on a's visible surface with flow
  double mean_error = 0.0;     // mean |r|, pixels
};

// The residual r = p_b - p_a - flow(p_a) of the dynamic Gaussians (rows
// [first, N) of `at_a`, posed at a's time) whose centre projects into a
// pixel of a with valid flow and lies on a's rendered surface (depth
// within `tolerance`, relative, of `rendered_depth` there); `means_b` are
// the same Gaussians' centres posed at b's time ((N - first) x 3). Huber
// with `huber_pixels`, normalised by a's width. Adds dL/dmeans into
// `d_means_a` (N x 3) and `d_means_b` ((N - first) x 3); the flow is held
// fixed. `flow` is H x W x 2 and `valid`, `rendered_depth` H x W at a's
// size.
template <typename T>
FlowTerm FlowLoss(const GaussianModelT<T>& at_a, std::size_t first,
                  const std::vector<T>& means_b,
                  const RasterCameraT<T>& camera_a,
                  const RasterCameraT<T>& camera_b,
                  const std::vector<float>& flow,
                  const std::vector<std::uint8_t>& valid,
                  const std::vector<float>& rendered_depth, double weight,
                  double tolerance, double huber_pixels,
                  std::vector<T>* d_means_a, std::vector<T>* d_means_b);

// Scale- and shift-invariant disparity (DynamicNeRF's, MiDaS'): a
// network's disparity is an affine of inverse depth with an unknown
// affine per frame, so the render's inverse depth is compared after the
// least-squares affine that maps the prior onto it:
//   weight x mean |s D + b - 1 / z| / median(1 / z)
// over pixels with a prior value and a rendered depth (the affine is
// refitted at every call and held fixed in the gradient).
struct DisparityTerm {
  double loss = 0.0;
  std::int64_t pixels = 0;
  double scale = 0.0, shift = 0.0;  // the affine fitted
};

// `disparity` and `rendered_depth` are H x W; adds dL/dz into
// `d_rendered_depth` (sized like it). Pixels where `disparity` is not
// finite or `rendered_depth` not positive are left out, and with `mask`
// (H x W, nonzero = in) those outside it: on a moving object's pixels the
// affine is the object's own, so the term holds the shape a network sees
// in it whatever its affine error across the frame.
DisparityTerm DisparityLoss(const std::vector<float>& disparity,
                            const std::vector<float>& rendered_depth,
                            double weight, std::vector<float>* d_rendered_depth,
                            const std::vector<std::uint8_t>* mask = nullptr);

}  // namespace pano4d
