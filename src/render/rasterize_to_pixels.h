#pragma once
// The rasterizer's last stage (gsplat's `rasterize_to_pixels`): front-to-
// back alpha blending of each tile's sorted Gaussians, and its backward,
// which walks the same pairs back to front from the forward's saved state.
// The per-pixel arithmetic both share is in blend_kernel.h.
#include <cstdint>
#include <vector>

#include "src/render/rasterizer.h"

namespace pano4d {

// Blends state->projected over state's width x height image through its
// sorted_ids and tile_ranges: alpha = min(0.99, o exp(power)), pairs under
// 1/255 skipped, a pixel stops before its transmittance falls below 1e-4.
// Writes *out and state's final_transmittance and last_contributor;
// returns the (Gaussian, pixel) pairs evaluated.
template <typename T>
std::uint64_t RasterizeToPixelsForward(const RasterSettingsT<T>& settings,
                                       RasterStateT<T>* state,
                                       RenderOutputT<T>* out);

// Gradients with respect to each projected Gaussian of `state` given those
// with respect to the forward's outputs `out` (sizes checked by the
// caller, RasterizerT::Backward). `entry_grads` is scratch. Deterministic
// whatever the thread count: per-entry gradients are reduced in entry
// order. Returns the (Gaussian, pixel) pairs evaluated.
template <typename T>
std::uint64_t RasterizeToPixelsBackward(const RasterSettingsT<T>& settings,
                                        const RasterStateT<T>& state,
                                        const RenderOutputT<T>& out,
                                        const RenderGradientsT<T>& d_out,
                                        std::vector<T>* entry_grads,
                                        ProjectedGradientsT<T>* grad);

// The blend's ceiling on this machine: its own lane loops (forward and
// backward, float) run over one tile and kProbeGaussians Gaussians that
// cover it and never stop a pixel, everything in L1: no gathers from
// memory, no partial boxes, no early termination. (Gaussian, pixel) pairs
// per second on `threads` threads, each its own tile, over at least
// `min_seconds`. A render's blend throughput over this says what its
// memory traffic, boxes and stops cost.
inline constexpr int kProbeGaussians = 64;
struct BlendCeiling {
  double forward_pairs_per_s = 0, backward_pairs_per_s = 0;
};
BlendCeiling ProbeBlendCeiling(int threads, double min_seconds);

}  // namespace pano4d
