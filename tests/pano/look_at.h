#pragma once
// Shared by the src/pano tests: a small pinhole camera aimed at a point.

#include <Eigen/Geometry>

#include "src/render/gaussians.h"

namespace pano4d::testing {

// A 64x48 camera (f = 50) at `eye` looking at `target`, world +z up (OpenCV
// axes: y down).
inline RasterCamera LookAt(const Eigen::Vector3f& eye,
                           const Eigen::Vector3f& target) {
  const Eigen::Vector3f forward = (target - eye).normalized();
  const Eigen::Vector3f right =
      forward.cross(Eigen::Vector3f::UnitZ()).normalized();
  Eigen::Matrix3f world_from_cam;
  world_from_cam << right, forward.cross(right), forward;
  RasterCamera c;
  c.width = 64;
  c.height = 48;
  c.fx = c.fy = 50;
  c.cx = 32;
  c.cy = 24;
  c.rotation = world_from_cam.transpose();
  c.translation = -(c.rotation * eye);
  return c;
}

}  // namespace pano4d::testing
