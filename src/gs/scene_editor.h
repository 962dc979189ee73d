#pragma once

#include <cstdint>
#include <vector>

#include "src/gs/scene.h"
#include "src/gs/training_view.h"
#include "src/render/rasterizer.h"

namespace pano4d {

// What the panoramic expansion (src/pano/expansion.h) needs of a fit in
// progress, and all it may do to it: render the current Gaussians, read
// the training views and the scene, add and remove static Gaussians (with
// their optimiser state and densification statistics). Trainer implements
// it; a test can implement it over a bare scene. ExtraView is what the
// expansion gives back: refinement views for the trainer's extra_view hook.
class SceneEditor {
 public:
  virtual ~SceneEditor() = default;
  // The scene at `time` seen by `camera`, in the Gaussians' own colours.
  virtual void Render(const RasterCamera& camera, int time,
                      RenderOutput* out) = 0;
  virtual const std::vector<TrainingView>& views() const = 0;
  virtual const GaussianScene& scene() const = 0;
  // Appends `extra` (the scene's SH degree, else pano4d::Error) to the
  // static Gaussians, as many as the fit's Gaussian cap allows; returns
  // the count added.
  virtual std::int64_t AddStaticGaussians(const GaussianModel& extra) = 0;
  // Removes the static Gaussians whose keep is 0 (one flag per static row,
  // else pano4d::Error); returns the count removed.
  virtual std::int64_t RemoveStaticGaussians(
      const std::vector<std::uint8_t>& keep) = 0;
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

}  // namespace pano4d
