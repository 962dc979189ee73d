#pragma once
// The rasterizer's first stage (gsplat's `projection`): each 3D Gaussian
// seen by a camera becomes a 2D one (pixel mean, conic, depth, opacity,
// view-dependent colour, footprint and tiles), and its backward carries
// gradients with respect to the 2D Gaussians to the model's parameters.
#include "src/render/gaussians.h"
#include "src/render/rasterizer.h"

namespace pano4d {

// Projects every Gaussian of `model` into `camera`: near-plane cull, EWA
// covariance with the 1.3 x FOV clamp and the 0.3 px low-pass, the box
// where alpha >= 1/255, 3-sigma radius and tiles, SH colour. A Gaussian
// that cannot contribute gets radius 0.
template <typename T>
void ProjectionForward(const GaussianModelT<T>& model,
                       const RasterCameraT<T>& camera,
                       ProjectedGaussiansT<T>* projected);

// From gradients with respect to the projected Gaussians (`grad2d`) to the
// model's parameters, given the forward's `projected` for this `model` and
// `camera`. Writes every entry of *grad (zero for culled Gaussians), and
// means2d as the pixel-mean gradient. Throws pano4d::Error naming both
// sizes when `projected` or `grad2d` hold another number of Gaussians than
// `model`.
template <typename T>
void ProjectionBackward(const GaussianModelT<T>& model,
                        const RasterCameraT<T>& camera,
                        const ProjectedGaussiansT<T>& projected,
                        const ProjectedGradientsT<T>& grad2d,
                        GaussianGradientsT<T>* grad);

}  // namespace pano4d
