#pragma once

#include <cstddef>
#include <cstdint>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "src/gs/strategy_options.h"

namespace pano4d {

// The depth loss' weight on depth the dataset gives (rendered, a depth
// sensor) and on depth pano4d estimated (stereo, or another tool's maps
// aligned to the SfM points), whose holes and errors a strong weight would
// bake into the geometry. The fit chooses by the frames' depth source
// (ResolveFitOptions, src/pipeline/fit_options.h).
inline constexpr double kGivenDepthWeight = 5.0;
inline constexpr double kEstimatedDepthWeight = 1.0;

// The training view whose colours the Gaussians hold (its appearance
// transform stays the identity; TrainerOptions::appearance).
inline constexpr std::size_t kAppearanceReferenceView = 0;

// A loss weight above this swamps the photometric term (weight 1) until
// float gradients overflow and every update is skipped (1e300 trained
// nothing, and the fit still reported success): a typo, refused by Check.
inline constexpr double kMaxLossWeight = 1e4;

struct TrainerOptions {
  int iterations = 10000;
  // Losses: (1 - ssim_weight) L1 + ssim_weight D-SSIM on the video; plus
  // depth_weight times the mean |rendered - given| / median given depth
  // over pixels with depth; plus the bases' acceleration penalty.
  double ssim_weight = 0.2;
  double depth_weight = kEstimatedDepthWeight;
  double smoothness_weight = 1.0;
  // Shape regulariser (PhysGaussian's): anisotropy_weight times the mean
  // over Gaussians of max(0, largest / smallest scale - max_anisotropy).
  // Needle-like Gaussians fit the training rays and streak across every
  // other view. 10 rather than 4 since the normal term flattens Gaussians
  // into discs, which a bound of 4 kept thick
  // (docs/experiments/2026-11-22-depth-normal-flatness.md).
  double anisotropy_weight = 0.1;
  double max_anisotropy = 10.0;
  // Depth-normal flatness (surface_loss.h): normal_weight times the mean
  // over the Gaussians on the surface a view's depth map shows (centre
  // within normal_tolerance, relative, of the depth) of the share of their
  // variance along the depth map's normal.
  double normal_weight = 0.1;
  double normal_tolerance = 0.03;
  // Hidden depth (surface_loss.h): hidden_weight times the mean over the
  // dynamic Gaussians inside a view's dynamic mask of
  // max(0, z / d - 1 - hidden_thickness): a moving object's Gaussians may
  // not hide deeper behind its visible surface than it is thick
  // (docs/experiments/2026-11-22-hidden-depth-term.md).
  double hidden_weight = 1.0;
  double hidden_thickness = 0.1;
  // Learned priors (prior_loss.h), on the views that carry them (--priors):
  // flow_weight times the mean Huber distance (flow_huber_pixels), over
  // the dynamic Gaussians on a view's rendered surface (centre within
  // flow_tolerance, relative, of its depth), between where the Gaussian
  // lands in the flow's other view and where the flow says, in units of
  // the image width; disparity_weight times the scale- and shift-invariant
  // error of the rendered inverse depth against the view's disparity.
  double flow_weight = 1.0;
  double flow_tolerance = 0.05;
  double flow_huber_pixels = 2.0;
  double disparity_weight = 1.0;
  // The disparity term on a view's moving pixels only (when it has a
  // dynamic mask), leaving the static ones to stereo alone.
  bool disparity_moving_only = false;
  // Per-frame appearance (appearance.h): an affine colour transform per
  // training frame applied to its render before the loss, learned at
  // lr_appearance and held near the identity by appearance_weight x
  // (|A - I|^2 + |b|^2); the first training frame (the reference) keeps
  // the identity, so the Gaussians hold its colours. false: the Gaussians'
  // colours explain every frame as it is.
  bool appearance = true;
  double appearance_weight = 0.1;
  double lr_appearance = 5e-3;  // decayed as the positions' rates
  // Learning rates (3DGS's; positions, basis translations times the scene
  // extent, decayed log-linearly to 1/100 over the run).
  double lr_mean = 1.6e-4;
  double lr_log_scale = 5e-3;
  double lr_quat = 1e-3;
  double lr_opacity = 5e-2;
  double lr_sh = 2.5e-3;
  double lr_logit = 1e-2;
  double lr_basis_rotation = 1e-4;
  double lr_basis_translation = 1.6e-4;
  // Densification and pruning (strategy_options.h; recorded flat among
  // these options in fit.json and the checkpoint).
  StrategyOptions strategy;
  // After every step a static Gaussian's scales are clamped to this many
  // pixels of the median training view at the median depth (16: the
  // largest initial scale, 8 voxels of the initialisation); 0: no clamp.
  // Without it a few static Gaussians grow to tens of voxels, and where one
  // lies in front of a validation view it veils it. 3DGS prunes such
  // Gaussians only after its first opacity reset, which a budget of 3000
  // iterations never reaches
  // (docs/experiments/2026-11-23-full-resolution-tracks-and-static-scale-clamp.md).
  double max_static_scale_pixels = 16.0;
  Eigen::Vector3f background = Eigen::Vector3f::Zero();

  void Check() const;  // throws pano4d::Error naming the field
  nlohmann::json ToJson() const;
};

}  // namespace pano4d
