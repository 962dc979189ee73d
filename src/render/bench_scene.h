#pragma once

#include <cstdint>

#include "src/render/gaussians.h"

namespace pano4d {

// The benchmark scene of `pano4d bench render`: `count` isotropic Gaussians
// filling the camera's view at depths 2..4, sized so that the mean projected
// 3-sigma radius is about `radius_px`, opacity 0.5, random colours (SH
// degree 0), from a fixed seed.
GaussianModel RandomViewFillingScene(std::size_t count,
                                     const RasterCamera& camera,
                                     float radius_px, std::uint32_t seed);

// A pinhole camera at the origin looking down +z with a 58-degree
// horizontal field of view.
RasterCamera BenchCamera(int width, int height);

}  // namespace pano4d
