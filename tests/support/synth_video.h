#pragma once

#include <cstdint>
#include <vector>

#include "src/core/posed_camera.h"
#include "src/datasets/synth_cameras.h"
#include "src/datasets/synth_render.h"
#include "src/datasets/synth_scene.h"

namespace pano4d::testing {

// The synthetic scene (seed 1) filmed more densely than the "tiny" preset
// (whose 8 frames are 8 degrees of orbit apart, a baseline where flow fails
// in many places): 24 frames at 256x192, 2.4 degrees apart, as a handheld
// video. Header-only; a test using it links pano4d_eval.
struct DenseSynthVideo {
  static constexpr int kWidth = 256, kHeight = 192, kFrames = 24;
  static constexpr std::uint32_t kSeed = 1;
  std::vector<PosedCamera> cameras;
  std::vector<synth::RenderedFrame> frames;  // shaded; frame t at t / 23
};

inline DenseSynthVideo FilmDenseSynthVideo(bool is_static) {
  using V = DenseSynthVideo;
  const synth::Scene scene = synth::BuildScene(V::kSeed, is_static);
  const double f = 0.9 * V::kWidth;
  const Camera intrinsics{CameraModelId::kPinhole,
                          V::kWidth,
                          V::kHeight,
                          {f, f, V::kWidth / 2.0, V::kHeight / 2.0}};
  V video;
  video.cameras =
      synth::TrainingTrajectory(scene, intrinsics, V::kFrames, V::kSeed);
  for (int t = 0; t < V::kFrames; ++t) {
    video.frames.push_back(synth::RenderFrame(scene, video.cameras[t],
                                              t / (V::kFrames - 1.0),
                                              /*shade=*/true, false));
  }
  return video;
}

}  // namespace pano4d::testing
