#pragma once

#include <vector>

#include <Eigen/Core>

#include "src/render/gaussians.h"

namespace pano4d {

// The paper's equirectangular mapping (Appendix, "Panoramic Projection"):
//   p~ = R_align^T (p - center)
//   phi = atan2(y~, x~),  theta = atan2(z~, sqrt(x~^2 + y~^2))
//   u = (phi / 2 pi + 0.5) width,  v = (0.5 - theta / pi) height
// so +x~ is the image centre, +z~ (up) the top row, and phi = +-pi the
// left/right edge (the seam). Pixel (i, j) covers [i, i + 1) x [j, j + 1).
struct EquirectProjection {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Matrix3d r_align = Eigen::Matrix3d::Identity();
  int width = 2048;
  int height = 2048;

  // Continuous (u, v); u in [0, width], v in [0, height].
  Eigen::Vector2d Project(const Eigen::Vector3d& point) const;
  // The unit world direction of (u, v): the inverse of Project.
  Eigen::Vector3d Direction(const Eigen::Vector2d& uv) const;
  // The pixel holding (u, v): columns wrap around the seam, rows clamp.
  Eigen::Vector2i Pixel(const Eigen::Vector2d& uv) const;
};

// An equirectangular image: RGB and the distance from the centre of the
// nearest surface (0 where nothing landed).
struct PanoramaImage {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;
  std::vector<float> distance;
};

// Z-buffered splat of coloured points: each covers a disc of
// `angular_radius` radians around its direction, so its footprint widens
// towards the poles (1 / cos(theta) horizontally) and wraps across the seam.
// The nearest point wins each pixel, whatever the order of the input.
PanoramaImage SplatPoints(const EquirectProjection& projection,
                          const std::vector<Eigen::Vector3f>& points,
                          const std::vector<Eigen::Vector3f>& colors,
                          double angular_radius);

// Gaussians as points: the mean, the degree-0 colour, and an angular radius
// of 3 sigma (largest scale) over the distance, at least one pixel.
PanoramaImage SplatGaussians(const EquirectProjection& projection,
                             const GaussianModel& model);

}  // namespace pano4d
