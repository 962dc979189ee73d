#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/core/posed_camera.h"
#include "src/datasets/synth_scene.h"

namespace pano4d::synth {

// Learned-like priors for a synthetic scene's training frames, written as
// the tools users run write them, so that `--priors SCENE` reads them as
// it reads Balloon1's: MiDaS-like disparity in DynamicNeRF's
// disp/<frame>.npy and RAFT-like flow between neighbouring frames in
// OmniMotion's raft_exhaustive/<a>.png_<b>.png.npy (no masks: the reader's
// forward-backward check makes them), both at 1x while the benchmark runs
// at 2x. The error models (PriorErrorModel) stand in for a network's: the
// truth is exact ground truth from the ray tracer.
struct PriorErrorModel {
  // Disparity = a (1 / z) (1 + e(x, y)) + b, per frame a and b drawn
  // log-uniformly in [disparity_scale_min, disparity_scale_max] and
  // uniformly in [0, disparity_shift_max] x a x the frame's mean 1 / z; e
  // a smooth field (a 4 x 3 grid of N(0, smooth_error) upsampled
  // bicubically); then blurred by a Gaussian of edge_blur_pixels (a
  // network's soft depth edges).
  double disparity_scale_min = 500, disparity_scale_max = 5000;
  double disparity_shift_max = 0.2;
  double smooth_error = 0.06;
  double edge_blur_pixels = 2.0;
  // Flow: the exact motion of each pixel's surface point, blurred by a
  // Gaussian of flow_blur_pixels (soft motion boundaries), plus
  // N(0, flow_noise_pixels) per component.
  double flow_blur_pixels = 1.5;
  double flow_noise_pixels = 0.3;
  nlohmann::json ToJson() const;
};

// One training frame: its 1x camera, the parts' poses at its time and its
// DyCheck id.
struct PriorFrameSource {
  PosedCamera camera;
  double time = 0;
  std::string id;
};

// Writes disp/ and raft_exhaustive/ (neighbouring frames, both ways) under
// `out`; the same seed gives the same bytes.
void WriteSynthPriors(const Scene& scene,
                      const std::vector<PriorFrameSource>& frames,
                      std::uint32_t seed, const PriorErrorModel& model,
                      const std::filesystem::path& out);

}  // namespace pano4d::synth
