#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/gs/adam.h"
#include "src/gs/appearance.h"
#include "src/gs/checkpoint.h"
#include "src/gs/loss.h"
#include "src/gs/scene.h"
#include "src/gs/scene_editor.h"
#include "src/gs/strategy.h"
#include "src/gs/trainer_options.h"
#include "src/gs/training_view.h"
#include "src/render/rasterizer.h"

namespace pano4d {

struct StepReport {
  std::int64_t iteration = 0;  // after the step
  double loss = 0.0;           // total
  double l1 = 0.0, ssim = 0.0, depth = 0.0, smoothness = 0.0, extra = 0.0,
         anisotropy = 0.0, normal = 0.0, hidden = 0.0, appearance = 0.0,
         flow = 0.0, disparity = 0.0;
  double psnr = 0.0;              // of this step's training view
  std::int64_t skipped_rows = 0;  // Gaussians with non-finite gradients
  bool skipped_step = false;      // the loss itself was not finite
};

// Time spent per phase, seconds, for the closing summary.
struct PhaseTimes {
  double compose = 0, forward = 0, loss = 0, backward = 0, motion = 0,
         optimise = 0, densify = 0;
};

class CheckpointReader;  // checkpoint.h
struct CheckpointState;

// A fit: 3D Gaussian splatting's training loop over the 4D scene. The
// expansion reaches it only through SceneEditor.
class Trainer : public SceneEditor {
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
              int appearance_view);
  void Render(const RasterCamera& camera, int time,
              RenderOutput* out) override {
    Render(camera, time, out, -1);
  }
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
  // (trainer_checkpoint.cc, src/gs/checkpoint.h).
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

  // The expansion's Gaussians in unseen regions, and those it carves, with
  // their optimiser state (DefaultStrategy::AddStatic / RemoveStatic;
  // removals count in pruned_total()).
  std::int64_t AddStaticGaussians(const GaussianModel& extra) override;
  std::int64_t RemoveStaticGaussians(
      const std::vector<std::uint8_t>& keep) override;

  const GaussianScene& scene() const override { return scene_; }
  const std::vector<TrainingView>& views() const override { return views_; }
  const TrainerOptions& options() const { return options_; }
  const PhaseTimes& times() const { return times_; }
  double extent() const { return extent_; }
  std::int64_t skipped_rows_total() const { return skipped_rows_total_; }
  std::int64_t skipped_steps_total() const { return skipped_steps_total_; }
  std::int64_t densified_total() const { return strategy_.densified_total(); }
  std::int64_t pruned_total() const { return strategy_.pruned_total(); }

 private:
  void RegisterGroups();
  RasterSettings Settings() const;
  // Resuming (trainer_checkpoint.cc): whether the file belongs to this run,
  // then its state restored.
  void Restore(const CheckpointReader& file);
  void CheckResumable(const CheckpointReader& file,
                      const CheckpointState& state) const;
  void RestoreArrays(const CheckpointReader& file,
                     const CheckpointState& state);
  int NextView();
  OptimisedScene Optimised() {
    return {&scene_, &static_adam_, &dynamic_adam_};
  }
  void UpdateLearningRates();
  // The steps of Step(), in order. The training view composed at its time
  // and rendered (out_, state_).
  void RenderView(const TrainingView& view);
  // Its losses (photometric through its appearance transform, depth,
  // surface, priors) into `report`, their gradients into d_out_ and
  // direct_grads_.
  void ViewLosses(const TrainingView& view, StepReport* report);
  void AppearanceBackward(std::size_t view_index, StepReport* report);
  // The depth-normal flatness and hidden-depth terms (surface_loss.h), on
  // the composed Gaussians themselves.
  void SurfaceLosses(const TrainingView& view, StepReport* report);
  // A non-finite loss: the step is counted, logged and skipped.
  StepReport SkipStep(const TrainingView& view, StepReport report);
  // The view's losses back to the static, dynamic and basis gradients;
  // the strategy's statistics.
  void BackpropViewLosses(const TrainingView& view);
  // The expansion's refinement view (extra_view), when it gives one.
  void AddRefinementView(StepReport* report);
  // The anisotropy and motion-smoothness terms on the parameters.
  void AddRegularisers(StepReport* report);
  // Adam on every group, then the static scale clamp.
  void OptimiserStep(StepReport* report);
  // The learned priors' losses on the training view's render (prior_loss.h):
  // disparity into d_out_.depth; flow into direct_grads_.means for this
  // time and into flow_backward_ for the flows' other times.
  void PriorLosses(const TrainingView& view, StepReport* report);
  // The flow loss' gradients at the other times, through the motion bases
  // into the dynamic and basis gradients.
  void PriorBackward();
  // Rasterizer backward of the forward that left `state` and `out` (the
  // composed model's at `camera`), plus (when `direct` is given) the
  // gradients that losses computed directly on the composed Gaussians,
  // into the static, dynamic and basis gradients.
  void Backprop(const RasterCamera& camera, int time, const RasterState& state,
                const RenderOutput& out, const RenderGradients& d_out,
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
  // Densification, pruning, opacity resets and the expansion's edits.
  DefaultStrategy strategy_;

  std::mt19937_64 rng_;
  std::vector<int> order_;
  std::size_t order_pos_ = 0;
  std::int64_t iteration_ = 0;

  // Per-step buffers, reused.
  Rasterizer rasterizer_;
  GaussianModel composed_;
  // The training view's forward and the refinement view's: the strategy
  // reads the first after the second has run.
  RasterState state_, extra_state_;
  RenderOutput out_, extra_out_;
  GaussianGradients grads_;
  // Gradients of the losses on the composed Gaussians themselves (the
  // flatness and hidden-depth terms): means, log_scales and quats, each
  // empty when no term set it.
  GaussianGradients direct_grads_;
  RenderGradients d_out_, d_extra_;
  std::vector<float> corrected_, d_corrected_, appearance_grads_;
  PhotometricLossBuffers loss_buffers_;
  GaussianGradients static_grads_, dynamic_grads_;
  std::vector<float> logit_grads_;
  MotionBases basis_grads_;
  // The flow loss' other times: the dynamic Gaussians posed there, and
  // the gradients of their means.
  struct FlowBackward {
    int time = 0;
    std::vector<float> d_means;
  };
  std::vector<FlowBackward> flow_backward_;
  GaussianModel flow_posed_;
  std::vector<float> flow_zero_quats_;

  PhaseTimes times_;
  std::int64_t skipped_rows_total_ = 0, skipped_steps_total_ = 0;
};

}  // namespace pano4d
