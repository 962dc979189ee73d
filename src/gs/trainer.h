#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/core/frames.h"
#include "src/gs/adam.h"
#include "src/gs/appearance.h"
#include "src/gs/scene.h"
#include "src/render/rasterizer.h"

namespace pano4d {

// A training frame in memory, at the resolution of its camera.
struct TrainingView {
  std::string name;
  int time = 0;
  RasterCamera camera;
  std::vector<float> rgb;             // H x W x 3
  std::vector<float> depth;           // H x W z-depth, 0 = none; may be empty
  std::vector<std::uint8_t> dynamic;  // H x W, 255 = dynamic; may be empty
};

// Reads the images, depth maps and dynamic masks of `frames`. Throws
// pano4d::Error naming the file that is missing, of another size than its
// camera, or holds NaN.
std::vector<TrainingView> LoadTrainingViews(
    const std::vector<WorkspaceFrame>& frames);

// The depth loss' weight on depth the dataset gives (rendered, a depth
// sensor) and on depth pano4d estimated (stereo, or another tool's maps
// aligned to the SfM points), whose holes and errors a strong weight would
// bake into the geometry. The fit chooses by the frames' depth source
// (ResolveFitOptions, src/pipeline/fit_options.h).
inline constexpr double kGivenDepthWeight = 5.0;

// The training view whose colours the Gaussians hold (its appearance
// transform stays the identity; TrainerOptions::appearance).
inline constexpr std::size_t kAppearanceReferenceView = 0;
inline constexpr double kEstimatedDepthWeight = 1.0;

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

// What the expansion stage adds to a step (DESIGN.md, eq. refine): a view
// at `camera` and `time` that should look like `target`. The loss is
//   weight / (3 |mask|) * (sum over the mask of |render - target|^2
//                          + outside_weight * the same sum outside it),
// the paper's masked MSE when outside_weight is 0; nothing when the mask is
// empty.
struct ExtraView {
  RasterCamera camera;
  int time = 0;
  std::vector<float> target;       // H x W x 3
  std::vector<std::uint8_t> mask;  // H x W, 255 = M_e (generated content)
  double weight = 0.1;
  double outside_weight = 0.0;
};

struct StepReport {
  std::int64_t iteration = 0;  // after the step
  double loss = 0.0;           // total
  double l1 = 0.0, ssim = 0.0, depth = 0.0, smoothness = 0.0, extra = 0.0,
         anisotropy = 0.0, normal = 0.0, hidden = 0.0, appearance = 0.0;
  double psnr = 0.0;              // of this step's training view
  std::int64_t skipped_rows = 0;  // Gaussians with non-finite gradients
  bool skipped_step = false;      // the loss itself was not finite
};

// Time spent per phase, seconds, for the closing summary.
struct PhaseTimes {
  double compose = 0, forward = 0, loss = 0, backward = 0, motion = 0,
         optimise = 0, densify = 0;
};

// The scene stored in a checkpoint (to construct the Trainer that
// LoadCheckpoint then restores). Throws pano4d::Error naming the file when
// it is not a pano4d checkpoint, is truncated or holds non-finite values.
// The byte overloads read a checkpoint in memory (`source` names it in
// errors); the path overloads read the file.
GaussianScene ReadCheckpointScene(const std::filesystem::path& path);
GaussianScene ReadCheckpointScene(std::vector<std::uint8_t> bytes,
                                  const std::string& source);
// The fingerprint a checkpoint was written with (Trainer::SetFingerprint);
// null for a checkpoint from before pano4d stored one.
nlohmann::json ReadCheckpointFingerprint(const std::filesystem::path& path);
nlohmann::json ReadCheckpointFingerprint(std::vector<std::uint8_t> bytes,
                                         const std::string& source);
// Both fingerprints from one read of the file: the options' (as above) and
// the scene's (ViewsFingerprint; empty before pano4d stored one).
struct CheckpointFingerprints {
  nlohmann::json options;
  std::string scene;
};
CheckpointFingerprints ReadCheckpointFingerprints(
    const std::filesystem::path& path);

// The scene the views show, as a checkpoint records it: a hash of their
// names, times, cameras, images, depth and dynamic masks.
std::string ViewsFingerprint(const std::vector<TrainingView>& views);

struct CheckpointFile;  // checkpoint.cc

class Trainer {
 public:
  // `seed` draws the training order (each view once per shuffled epoch).
  Trainer(GaussianScene scene, std::vector<TrainingView> views,
          TrainerOptions options, std::uint64_t seed);
  // The optimisers hold pointers into the scene: not copyable or movable.
  Trainer(const Trainer&) = delete;
  Trainer& operator=(const Trainer&) = delete;

  // One iteration: a training view (each once per shuffled epoch), render,
  // losses, backward, Adam, densification on schedule. Non-finite gradients
  // are skipped row by row (counted in the report); a non-finite loss skips
  // the whole step. Both are logged.
  StepReport Step();
  bool Done() const { return iteration_ >= options_.iterations; }
  std::int64_t iteration() const { return iteration_; }

  // Renders the scene at `time` (between steps): its colours as the
  // Gaussians hold them, or, with `appearance_view` >= 0, as that training
  // view's camera records them (its appearance transform, when the trainer
  // learns them).
  void Render(const RasterCamera& camera, int time, RenderOutput* out,
              int appearance_view = -1);
  // Training view i's appearance transform (kAppearanceWidth floats; the
  // identity when appearance is off).
  const float* appearance(std::size_t view) const {
    return &appearance_[view * kAppearanceWidth];
  }

  // The expansion stage's hook: called at every step; a view returned is
  // rendered and its loss added to the step.
  std::function<const ExtraView*(std::int64_t iteration)> extra_view;
  // Tests only: called with the composed model's gradients before the
  // optimiser sees them (e.g. to inject a NaN).
  std::function<void(GaussianGradients*)> gradient_hook;

  // Everything a resumed run needs to continue as if never stopped
  // (parameters, optimiser moments, densification statistics, the random
  // generator, the epoch order) and the fingerprint, written atomically
  // (checkpoint.cc).
  void SaveCheckpoint(const std::filesystem::path& path) const;
  // Throws pano4d::Error naming the file when it is corrupt (its checksum,
  // an iteration outside this run's), belongs to other frames or another
  // scene (ViewsFingerprint), or holds another fingerprint (naming the
  // first key that differs and both values).
  void LoadCheckpoint(const std::filesystem::path& path);
  void LoadCheckpoint(std::vector<std::uint8_t> bytes,
                      const std::string& source);
  // What a run resuming from this trainer's checkpoints must share with the
  // run that wrote them: the trainer's options, unless the caller owns more
  // (the fit's resume fingerprint, src/pipeline/fit_options.h).
  void SetFingerprint(nlohmann::json fingerprint);

  // Appends `extra` (the scene's SH degree) to the static Gaussians with
  // fresh optimiser state (the expansion's Gaussians in unseen regions).
  // Beyond max_gaussians the rows that do not fit are dropped. Returns the
  // count added.
  std::int64_t AddStaticGaussians(const GaussianModel& extra);
  // Removes the static Gaussians whose `keep` is 0 (one per static row), with
  // their optimiser state. Counted in pruned_total(). Returns the count.
  std::int64_t RemoveStaticGaussians(const std::vector<std::uint8_t>& keep);

  const GaussianScene& scene() const { return scene_; }
  const std::vector<TrainingView>& views() const { return views_; }
  const TrainerOptions& options() const { return options_; }
  const PhaseTimes& times() const { return times_; }
  double extent() const { return extent_; }
  std::int64_t skipped_rows_total() const { return skipped_rows_total_; }
  std::int64_t skipped_steps_total() const { return skipped_steps_total_; }
  std::int64_t densified_total() const { return densified_total_; }
  std::int64_t pruned_total() const { return pruned_total_; }

 private:
  void RegisterGroups();
  RasterSettings Settings() const;
  void Restore(const CheckpointFile& file);
  int NextView();
  void Densify(bool prune_large);
  void ResetOpacities();
  void UpdateLearningRates();
  // Rasterizer backward from d_rgb and d_depth, plus (when `direct` is
  // given) the gradients that losses computed directly on the
  // composed Gaussians, into the static, dynamic and basis gradients.
  void Backprop(const RasterCamera& camera, int time, const RenderOutput& out,
                const std::vector<float>& d_rgb,
                const std::vector<float>& d_depth,
                const GaussianGradients* direct = nullptr);

  TrainerOptions options_;
  nlohmann::json fingerprint_;
  GaussianScene scene_;
  std::vector<TrainingView> views_;
  std::string scene_fingerprint_;  // ViewsFingerprint(views_)
  double extent_ = 1.0;
  std::vector<float> median_depth_;  // per view, 0 when it has none
  // log of options_.max_static_scale_pixels in world units; +inf: none.
  float max_static_log_scale_ = std::numeric_limits<float>::infinity();

  Adam static_adam_, dynamic_adam_, basis_adam_, appearance_adam_;
  // Per training view, kAppearanceWidth floats (appearance.h).
  std::vector<float> appearance_;
  int static_mean_group_ = -1, dynamic_mean_group_ = -1,
      basis_translation_group_ = -1;
  // Densification statistics per Gaussian (static rows, then dynamic).
  std::vector<float> grad_accum_, max_radius_;
  std::vector<std::int32_t> grad_count_;

  std::mt19937_64 rng_;
  std::vector<int> order_;
  std::size_t order_pos_ = 0;
  std::int64_t iteration_ = 0;
  bool reset_done_ = false;

  // Per-step buffers, reused.
  Rasterizer rasterizer_;
  GaussianModel composed_;
  RenderOutput out_;
  GaussianGradients grads_;
  // Gradients of the losses on the composed Gaussians themselves (the
  // flatness and hidden-depth terms): means, log_scales and quats, each
  // empty when no term set it.
  GaussianGradients direct_grads_;
  ProjectedGradients grads2d_;
  std::vector<float> d_rgb_, d_depth_, d_rgb_extra_;
  std::vector<float> corrected_, d_corrected_, appearance_grads_;
  GaussianGradients static_grads_, dynamic_grads_;
  std::vector<float> logit_grads_;
  MotionBases basis_grads_;

  PhaseTimes times_;
  std::int64_t skipped_rows_total_ = 0, skipped_steps_total_ = 0;
  std::int64_t densified_total_ = 0, pruned_total_ = 0;
};

}  // namespace pano4d
