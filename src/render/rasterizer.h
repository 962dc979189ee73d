#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "src/render/gaussians.h"

namespace pano4d {

// Numeric guards of the rasterizer, as in 3D Gaussian splatting:
// Points closer than this to the camera plane are culled: the EWA Jacobian
// grows as 1/z^2.
inline constexpr float kNearPlane = 0.01f;
// Added to the 2D covariance: a pixel-sized low-pass so that a Gaussian
// thinner than a pixel still covers one (anti-aliasing).
inline constexpr float kLowPass = 0.3f;
// The Jacobian is evaluated with the point clamped to 1.3 x the field of
// view: points far outside the image would otherwise get huge footprints.
inline constexpr float kFovClamp = 1.3f;
// Alpha never reaches 1, so transmittance stays invertible for backward.
inline constexpr float kMaxAlpha = 0.99f;
// Contributions under 1/255 cannot change an 8-bit pixel: skipped.
inline constexpr float kMinAlpha = 1.0f / 255.0f;
// Blending stops once less than this much light gets through.
inline constexpr float kMinTransmittance = 1e-4f;
// A quaternion shorter than this is treated as the identity rotation
// instead of dividing by (almost) zero.
inline constexpr float kMinQuaternionNorm = 1e-12f;
// Margin (pixels) added to the alpha >= kMinAlpha box against rounding: a
// pixel just outside the exact box must not be the one the alpha test
// would have accepted.
inline constexpr float kAlphaBoxMargin = 0.01f;
// Footprint radii are clamped here (pixels) so that enormous Gaussians do
// not overflow the integer tile arithmetic; the tile range clamps anyway.
inline constexpr float kMaxRadius = 1e6f;
// Expected depth divides by accumulated alpha; below this the pixel holds
// no surface and its depth is 0.
inline constexpr float kMinAlphaForDepth = 1e-6f;
inline constexpr int kTileSize = 16;

template <typename T>
struct RasterSettingsT {
  Eigen::Matrix<T, 3, 1> background = Eigen::Matrix<T, 3, 1>::Zero();
};

// What a forward pass produces: row-major images.
template <typename T>
struct RenderOutputT {
  int width = 0;
  int height = 0;
  std::vector<T> rgb;    // H x W x 3, background composited
  std::vector<T> depth;  // H x W, expected z-depth (0 where alpha ~ 0)
  std::vector<T> alpha;  // H x W, accumulated opacity
};

// The per-Gaussian result of projection, structure of arrays. A culled
// Gaussian has radius 0.
template <typename T>
struct ProjectedGaussiansT {
  std::vector<T> x, y;   // pixel position of the mean
  std::vector<T> depth;  // camera z
  std::vector<T> conic_a, conic_b,
      conic_c;              // inverse 2D covariance [a b; b c]
  std::vector<T> opacity;   // sigmoid of the logit
  std::vector<T> r, g, b;   // view-dependent colour
  std::vector<int> radius;  // 3 sigma, pixels; 0 = culled
  // Half-size of the box holding every pixel where alpha >= kMinAlpha: the
  // blend loop visits only those pixels of each tile (the others would be
  // skipped by the alpha test anyway, so results are unchanged).
  std::vector<T> extent_x, extent_y;
  // Tiles touched, [x0, x1) x [y0, y1).
  std::vector<int> tile_x0, tile_y0, tile_x1, tile_y1;
  std::vector<std::uint8_t> clamped;  // N x 3: SH colour hit max(0, .)
  void Resize(std::size_t n);
};

// Counts from the last forward pass, for benchmarks.
struct RasterStats {
  std::uint64_t visible = 0;            // Gaussians that survived projection
  std::uint64_t tile_entries = 0;       // (Gaussian, tile) pairs
  std::uint64_t pixel_evaluations = 0;  // (Gaussian, pixel) pairs blended
  // Wall time of the forward's stages, milliseconds.
  double project_ms = 0, bin_ms = 0, blend_ms = 0;
};

// Gradients of a loss with respect to the projected (2D) Gaussians: what
// the blend backward produces and the projection backward consumes.
template <typename T>
struct ProjectedGradientsT {
  std::vector<T> x, y;                       // pixel position of the mean
  std::vector<T> conic_a, conic_b, conic_c;  // inverse 2D covariance
  std::vector<T> opacity;                    // the sigmoid's output
  std::vector<T> r, g, b;                    // colour
  std::vector<T> depth;        // camera z (through expected depth)
  void Assign(std::size_t n);  // n zeros in every array
};

// Gradients of a loss with respect to the model's parameters, laid out as
// GaussianModelT, plus the screen-space (pixel) gradient of each mean that
// densification looks at.
template <typename T>
struct GaussianGradientsT {
  std::vector<T> means, log_scales, quats, opacities, sh;
  std::vector<T> means2d;                       // N x 2
  void Assign(const GaussianModelT<T>& model);  // zeros, sized like the model
};

// A tiled CPU rasterizer. Buffers live in the object and are reused, so
// steady-state rendering does not allocate. Results, gradients included, do
// not depend on the number of threads: tiles are independent, the sort is
// total and per-entry gradients are reduced in order.
template <typename T>
class RasterizerT {
 public:
  // Bins and blends given projected Gaussians (the 2D stage alone, e.g. to
  // check its gradients by finite differences); Forward is Project + this.
  void ForwardProjected(const ProjectedGaussiansT<T>& projected,
                        const RasterCameraT<T>& camera,
                        const RasterSettingsT<T>& settings,
                        RenderOutputT<T>* out);

  // The blend's backward, from the last forward's saved state (final
  // transmittance, last contributor, sorted ids): gradients of the loss with
  // respect to each projected Gaussian, given its gradients with respect to
  // the outputs (H x W x 3, H x W, H x W; an empty vector means zero).
  // Deterministic whatever the thread count: per-entry gradients are
  // reduced in entry order.
  void BlendBackward(const RasterCameraT<T>& camera,
                     const RasterSettingsT<T>& settings,
                     const RenderOutputT<T>& out, const std::vector<T>& d_rgb,
                     const std::vector<T>& d_depth,
                     const std::vector<T>& d_alpha,
                     ProjectedGradientsT<T>* grad);

  // The projection's backward: from the 2D gradients of BlendBackward to
  // the model's parameters. `model` and `camera` must be the last forward's;
  // a model or 2D gradients of another size than that forward's throw
  // pano4d::Error naming both sizes.
  void ProjectBackward(const GaussianModelT<T>& model,
                       const RasterCameraT<T>& camera,
                       const ProjectedGradientsT<T>& grad2d,
                       GaussianGradientsT<T>* grad) const;

  void Forward(const GaussianModelT<T>& model, const RasterCameraT<T>& camera,
               const RasterSettingsT<T>& settings, RenderOutputT<T>* out);

  // Forward state kept for the backward pass.
  const ProjectedGaussiansT<T>& projected() const { return projected_; }
  const std::vector<T>& final_transmittance() const { return final_t_; }
  const std::vector<std::uint32_t>& last_contributor() const { return last_; }
  const std::vector<std::uint32_t>& sorted_ids() const { return ids_; }
  // [begin, end) into sorted_ids() for each tile.
  const std::vector<std::uint32_t>& tile_ranges() const { return ranges_; }
  const RasterStats& stats() const { return stats_; }

 private:
  void Project(const GaussianModelT<T>& model, const RasterCameraT<T>& camera);
  void Bin(const RasterCameraT<T>& camera);
  void Blend(const RasterCameraT<T>& camera, const RasterSettingsT<T>& settings,
             RenderOutputT<T>* out);

  ProjectedGaussiansT<T> projected_;
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> ids_;
  std::vector<std::uint64_t> key_scratch_;  // radix sort buffers
  std::vector<std::uint32_t> scratch_;      // ids being permuted
  std::vector<std::uint32_t> offsets_;
  std::vector<std::uint32_t> ranges_;
  std::vector<T> final_t_;
  std::vector<std::uint32_t> last_;
  RasterStats stats_;
  std::vector<T> entry_grads_;  // blend backward: 10 per (tile, Gaussian) entry
};

using RasterSettings = RasterSettingsT<float>;
using RenderOutput = RenderOutputT<float>;
using ProjectedGaussians = ProjectedGaussiansT<float>;
using Rasterizer = RasterizerT<float>;
using ProjectedGradients = ProjectedGradientsT<float>;
using GaussianGradients = GaussianGradientsT<float>;

}  // namespace pano4d
