#pragma once

// The densification strategy's options (strategy.h), as gsplat's
// DefaultStrategy fields: 3DGS's adaptive density control.

#include <cstdint>

#include <nlohmann/json.hpp>

namespace pano4d {

struct StrategyOptions {
  // Densification (3DGS): every densify_every iterations in
  // [densify_from, densify_until), Gaussians whose mean screen-space
  // gradient (in NDC units) exceeds the threshold are cloned when small
  // (largest scale <= percent_dense x extent) and split in two when large.
  int densify_from = -1;   // -1: 500 (3DGS's), or half of densify_until
  int densify_until = -1;  // -1: half the iterations
  int densify_every = 100;
  double densify_gradient = 2e-4;
  double percent_dense = 0.01;
  // Pruning: opacity below this; after the first opacity reset also screen
  // radius above max_screen_radius pixels or scale above 0.1 extent.
  double prune_opacity = 0.005;
  double max_screen_radius = 20.0;
  // Opacities are reset to at most 0.01 every this many iterations while
  // densifying (3DGS), so that floaters can fade and be pruned.
  int opacity_reset_every = 3000;
  std::int64_t max_gaussians = 500000;

  void Check() const;  // throws pano4d::Error naming the field
  nlohmann::json ToJson() const;
};

}  // namespace pano4d
