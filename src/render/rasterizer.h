#pragma once
// The CPU rasterizer of 3D Gaussian splatting, in gsplat's stages:
//   projection            ProjectionForward / ProjectionBackward
//                         (projection.h; its arithmetic in ewa.h)
//   tile intersection     IntersectTiles (tile_intersection.h)
//   rasterize to pixels   RasterizeToPixelsForward / ...Backward
//                         (rasterize_to_pixels.h)
// RasterizerT composes them: Forward returns the forward's state (a
// RasterStateT the caller keeps) and Backward takes it, checked against the
// model and camera it is given.
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

// Gradients of a loss with respect to a RenderOutputT, in its layout; an
// empty vector means zero.
template <typename T>
struct RenderGradientsT {
  std::vector<T> rgb, depth, alpha;
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
  std::size_t size() const { return radius.size(); }
};

// Counts and stage times of one forward pass, for benchmarks.
struct RasterStats {
  std::uint64_t visible = 0;            // Gaussians that survived projection
  std::uint64_t tile_entries = 0;       // (Gaussian, tile) pairs
  std::uint64_t pixel_evaluations = 0;  // (Gaussian, pixel) pairs blended
  // Wall time of the forward's stages, milliseconds.
  double project_ms = 0, bin_ms = 0, blend_ms = 0;
};

// Wall time of a backward's stages, milliseconds.
struct RasterBackwardStats {
  double blend_ms = 0, project_ms = 0;
  std::uint64_t pixel_evaluations = 0;  // (Gaussian, pixel) pairs
};

// What a forward pass saves for its backward (gsplat's saved tensors).
// Backward checks that it belongs to the model and camera it is given.
template <typename T>
struct RasterStateT {
  int width = 0, height = 0;
  ProjectedGaussiansT<T> projected;  // one per Gaussian of the model
  // Gaussian of each (tile, Gaussian) entry, sorted by tile, then depth,
  // then index: a total order.
  std::vector<std::uint32_t> sorted_ids;
  // [begin, end) into sorted_ids for each tile: 2 per tile, row-major.
  std::vector<std::uint32_t> tile_ranges;
  // The inverse: Gaussian i's entries (positions in sorted_ids), in its
  // tiles' row-major order, are gaussian_entries[gaussian_offsets[i] ..
  // gaussian_offsets[i + 1]); the backward sums each Gaussian's gradient
  // over them, Gaussians in parallel.
  std::vector<std::uint32_t> gaussian_offsets, gaussian_entries;
  std::vector<T> final_transmittance;  // per pixel
  // Per pixel: one past the last entry of its tile that blended into it.
  std::vector<std::uint32_t> last_contributor;
  RasterStats stats;
  std::size_t gaussians() const { return projected.size(); }
};

// Gradients of a loss with respect to the projected (2D) Gaussians: what
// the rasterization backward produces and the projection backward consumes.
template <typename T>
struct ProjectedGradientsT {
  std::vector<T> x, y;                       // pixel position of the mean
  std::vector<T> conic_a, conic_b, conic_c;  // inverse 2D covariance
  std::vector<T> opacity;                    // the sigmoid's output
  std::vector<T> r, g, b;                    // colour
  std::vector<T> depth;        // camera z (through expected depth)
  void Assign(std::size_t n);  // n zeros in every array
  void Resize(std::size_t n);  // n values in every array, as they come
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

// The tile intersection's buffers, reused between calls: the visible
// Gaussians and their depth keys (sorted), and a cursor per tile and
// thread.
struct TileSortBuffers {
  std::vector<std::uint32_t> order, order_scratch, keys, key_scratch, cursor;
  struct Rect {  // a visible Gaussian's tiles [x0, x1) x [y0, y1)
    int x0, x1, y0, y1;
    std::uint32_t g, offset;  // its index and its first inverse entry
  };
  std::vector<Rect> rects;  // in depth order
};

// The stages composed, with the scratch buffers that make steady-state
// rendering allocation-free. Results, gradients included, do not depend on
// the number of threads: tiles are independent, the sort is total and
// per-entry gradients are reduced in order.
template <typename T>
class RasterizerT {
 public:
  // Renders `model` at `camera` into *out; *state receives what Backward
  // needs (reuse one state per pass that will be differentiated).
  void Forward(const GaussianModelT<T>& model, const RasterCameraT<T>& camera,
               const RasterSettingsT<T>& settings, RenderOutputT<T>* out,
               RasterStateT<T>* state);

  // Gradients of the loss with respect to `model`'s parameters, given its
  // gradients with respect to Forward's outputs. `state` and `out` must be
  // Forward's for this model and camera: a state of another number of
  // Gaussians or image size, or gradients of another size than the image,
  // throw pano4d::Error naming both sizes.
  RasterBackwardStats Backward(const GaussianModelT<T>& model,
                               const RasterCameraT<T>& camera,
                               const RasterSettingsT<T>& settings,
                               const RasterStateT<T>& state,
                               const RenderOutputT<T>& out,
                               const RenderGradientsT<T>& d_out,
                               GaussianGradientsT<T>* grad);

  // Forward whose state is not kept: for renders no backward follows.
  void Render(const GaussianModelT<T>& model, const RasterCameraT<T>& camera,
              const RasterSettingsT<T>& settings, RenderOutputT<T>* out);

  // The 2D stages alone (tile intersection and rasterization) on given
  // projected Gaussians, and their backward to the projected Gaussians:
  // to check those gradients by finite differences.
  void RasterizeForward(const ProjectedGaussiansT<T>& projected,
                        const RasterCameraT<T>& camera,
                        const RasterSettingsT<T>& settings,
                        RenderOutputT<T>* out, RasterStateT<T>* state);
  // Returns the backward's (Gaussian, pixel) pairs.
  std::uint64_t RasterizeBackward(const RasterCameraT<T>& camera,
                                  const RasterSettingsT<T>& settings,
                                  const RasterStateT<T>& state,
                                  const RenderOutputT<T>& out,
                                  const RenderGradientsT<T>& d_out,
                                  ProjectedGradientsT<T>* grad2d);

 private:
  void Intersect(const RasterCameraT<T>& camera, RasterStateT<T>* state);

  TileSortBuffers sort_;
  std::vector<T> entry_grads_;  // rasterization backward, per entry
  ProjectedGradientsT<T> grad2d_;
  RasterStateT<T> render_state_;  // Render's
};

using RasterSettings = RasterSettingsT<float>;
using RenderOutput = RenderOutputT<float>;
using RenderGradients = RenderGradientsT<float>;
using ProjectedGaussians = ProjectedGaussiansT<float>;
using RasterState = RasterStateT<float>;
using Rasterizer = RasterizerT<float>;
using ProjectedGradients = ProjectedGradientsT<float>;
using GaussianGradients = GaussianGradientsT<float>;

}  // namespace pano4d
