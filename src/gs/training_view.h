#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "src/core/frames.h"
#include "src/render/gaussians.h"

namespace pano4d {

// A training frame in memory, at the resolution of its camera.
struct TrainingView {
  std::string name;
  int time = 0;
  RasterCamera camera;
  std::vector<float> rgb;             // H x W x 3
  std::vector<float> depth;           // H x W z-depth, 0 = none; may be empty
  std::vector<std::uint8_t> dynamic;  // H x W, 255 = dynamic; may be empty

  // Learned priors (--priors, src/datasets/priors.h), at the view's size;
  // empty when the priors hold none for this frame.
  // A network's disparity (inverse depth up to an unknown affine), NaN
  // where it has none.
  std::vector<float> disparity;
  // Flow to another training view: pixel x of this view sees what x +
  // flow(x) of views[view] sees, where valid (255).
  struct Flow {
    int view = 0;
    std::vector<float> flow;            // H x W x 2, pixels
    std::vector<std::uint8_t> valid;    // H x W
  };
  std::vector<Flow> flows;
};

// Reads the images, depth maps and dynamic masks of `frames`. Throws
// pano4d::Error naming the file that is missing, of another size than its
// camera, or holds NaN.
std::vector<TrainingView> LoadTrainingViews(
    const std::vector<WorkspaceFrame>& frames);

}  // namespace pano4d
