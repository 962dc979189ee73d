#pragma once

// What the expansion leaves for people beside its own products (src/pano
// writes the warped, masked and refined frames): equirectangular panoramas
// of the fitted Gaussians, and for the ablation without Gaussian refinement
// the validation views made from the panoramic representation.

#include <filesystem>
#include <vector>

#include "src/gs/scene.h"
#include "src/gs/trainer.h"
#include "src/pano/expansion.h"
#include "src/pano/frame.h"
#include "src/pano/trajectory_io.h"
#include "src/pipeline/fit.h"

namespace pano4d {

// Panoramas are written at this aspect (equirectangular: 2 x 1).
inline constexpr int kPanoramaAspect = 2;

// dir/<t>.png for every time (all Gaussians posed at t) and dir/static.png
// (static Gaussians only: the content aggregated over time), equirectangular
// in the panorama frame, width x height.
void WritePanoramas(const std::filesystem::path& dir,
                    const GaussianScene& scene, const PanoramaFrame& frame,
                    int width, int height);

// The training views' cameras, to show beside the expanded ones
// (WriteTrajectories).
std::vector<SourceCamera> SourceCamerasOf(
    const std::vector<TrainingView>& views);

// --no-gaussian-refinement: the validation views made from the panoramic
// representation (Expansion::PanoramicViews), one trajectory per validation
// camera (frames sharing a pose), written as renders/<frame>.png.
void WritePanoramaResults(Trainer* trainer, Expansion* expansion,
                          const std::vector<ValidationView>& val,
                          const std::filesystem::path& renders);

}  // namespace pano4d
