#pragma once

#include <vector>

#include <Eigen/Core>

#include "src/render/gaussians.h"
#include "src/render/panorama.h"

namespace pano4d {

// The panorama's frame (DESIGN.md, "Panorama frame"): centre P_c and
// R_align, whose columns are the panorama's x~ (the first camera's viewing
// direction, levelled), y~ and z~ (up) in world coordinates.
struct PanoramaFrame {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Matrix3d r_align = Eigen::Matrix3d::Identity();

  EquirectProjection Projection(int width, int height) const;
};

// P_c: the centroid of `points` (the denoised cloud, or the Gaussians'
// means). Up: the mean of the cameras' up vectors (-y of each camera).
// Throws pano4d::Error when there are no points or cameras, a point is not
// finite, the up vectors cancel, or the first camera looks straight up or
// down.
PanoramaFrame MakePanoramaFrame(const std::vector<Eigen::Vector3f>& points,
                                const std::vector<RasterCamera>& cameras);

}  // namespace pano4d
