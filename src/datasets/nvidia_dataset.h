#pragma once

#include <filesystem>

#include "src/core/npy.h"
#include "src/datasets/dataset.h"

namespace pano4d {

// Nvidia Dynamic Scenes as packaged for monocular dynamic view synthesis
// (NSFF, DynamicNeRF): a scene folder (or its dense/ subfolder) holding
//   poses_bounds.npy   N x 17 float64, LLFF: a 3x5 camera-to-world matrix
//                      with columns [down, right, backwards, centre, (H, W,
//                      f)], then near and far bounds
//   images/ or images_<factor>/   the monocular video, frame i = camera i at
//   time i mv_images/<t:05d>/cam01.jpg   (NSFF) or gt/v000_t<t:03d>.png
//   (DynamicNeRF):
//                      view 0 at time t, the test frames
// Protocol (DynamicNeRF's): camera i at time i trains; view 0 at every time
// tests. Intrinsics: f from the hwf column, principal point at the image
// centre, scaled to the size of the images present (or hwf / factor).
bool LooksLikeNvidia(const std::filesystem::path& root);
Dataset ReadNvidia(const std::filesystem::path& root, int factor);

// The LLFF pose rows of poses_bounds.npy as OpenCV cameras at width x height
// (throws pano4d::Error for a shape other than N x 17 or bad values).
struct LlffCamera {
  PosedCamera camera;
  double near = 0.0;
  double far = 0.0;
};
std::vector<LlffCamera> LlffCameras(const NpyArray& poses_bounds,
                                    const std::string& source, int width = 0,
                                    int height = 0);

}  // namespace pano4d
