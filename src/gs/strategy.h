#pragma once
// How the Gaussians' number changes during a fit: 3D Gaussian splatting's
// adaptive density control (clone, split, prune, opacity reset) as a
// strategy over the scene and the optimiser state that follows its rows,
// in the manner of gsplat's DefaultStrategy. The trainer calls it at three
// points of a step; the expansion's additions and removals go through it
// too, so that statistics and optimiser rows never fall out of step with
// the scene.
#include <cstdint>
#include <random>
#include <vector>

#include "src/gs/adam.h"
#include "src/gs/scene.h"
#include "src/gs/strategy_options.h"
#include "src/render/rasterizer.h"

namespace pano4d {

// The scene and the optimisers whose rows follow its Gaussians: `statics`
// has the static model's five groups, `dynamics` the dynamic model's and
// then the logits.
struct OptimisedScene {
  GaussianScene* scene;
  Adam* statics;
  Adam* dynamics;
};

// Per Gaussian (static rows, then dynamic: the composed order) since the
// last densification; checkpoints store them.
struct DensifyStatistics {
  std::vector<float> gradient;      // summed screen-space gradient norms
  std::vector<std::int32_t> count;  // steps in which the Gaussian was seen
  std::vector<float> max_radius;    // largest screen radius, pixels
  bool reset_done = false;          // an opacity reset has happened
  void Assign(std::size_t n);       // n zero rows
};

class DefaultStrategy {
 public:
  // `options` with densify_from and densify_until resolved (the trainer
  // resolves -1); `extent` scales the clone/split and world-size bounds.
  DefaultStrategy(const StrategyOptions& options, double extent,
                  std::size_t gaussians);
  DefaultStrategy() = default;  // no Gaussians; assign a configured one

  // Before the forward of the step that follows `iteration` steps: 3DGS's
  // opacity reset after every opacity_reset_every steps while densifying
  // (so that what was validated or saved at that iteration is the model
  // before the reset).
  void StepPreForward(std::int64_t iteration, OptimisedScene scene);
  // After the training view's backward: each visible Gaussian's
  // screen-space gradient (NDC units, as 3DGS's threshold assumes) and
  // radius, from that view's forward state.
  void StepPostBackward(const RasterState& state,
                        const GaussianGradients& grads);
  // After the optimiser has made step `iteration` (counted from 1):
  // densification and pruning on their schedule. Splits draw from `rng`.
  void StepPostOptimise(std::int64_t iteration, OptimisedScene scene,
                        std::mt19937_64* rng);

  // Appends `extra` (the scene's SH degree) to the static Gaussians with
  // fresh optimiser state; beyond max_gaussians the rows that do not fit
  // are dropped. Returns the count added.
  std::int64_t AddStatic(OptimisedScene scene, const GaussianModel& extra);
  // Removes the static Gaussians whose keep is 0 (one flag per static row)
  // with their optimiser state; counted in pruned_total. Returns the count.
  std::int64_t RemoveStatic(OptimisedScene scene,
                            const std::vector<std::uint8_t>& keep);

  DensifyStatistics& statistics() { return stats_; }
  const DensifyStatistics& statistics() const { return stats_; }
  std::int64_t densified_total() const { return densified_total_; }
  std::int64_t pruned_total() const { return pruned_total_; }
  void set_totals(std::int64_t densified, std::int64_t pruned) {
    densified_total_ = densified;
    pruned_total_ = pruned;
  }

 private:
  void Densify(OptimisedScene scene, std::mt19937_64* rng);
  void ResetOpacities(OptimisedScene scene);

  StrategyOptions options_;
  double extent_ = 1.0;
  DensifyStatistics stats_;
  std::int64_t densified_total_ = 0, pruned_total_ = 0;
};

}  // namespace pano4d
