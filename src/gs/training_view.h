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
};

// Reads the images, depth maps and dynamic masks of `frames`. Throws
// pano4d::Error naming the file that is missing, of another size than its
// camera, or holds NaN.
std::vector<TrainingView> LoadTrainingViews(
    const std::vector<WorkspaceFrame>& frames);

}  // namespace pano4d
