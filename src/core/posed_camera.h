#pragma once

#include <optional>

#include <Eigen/Core>

#include "src/core/camera.h"
#include "src/core/rigid.h"

namespace pano4d {

// A camera with its pose: what a dataset frame or a COLMAP image provides.
struct PosedCamera {
  Camera camera;
  Rigid3d cam_from_world;

  Eigen::Vector3d Center() const { return CameraCenter(cam_from_world); }
  // World point to pixel; nullopt as Camera::Project.
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& world) const {
    return camera.Project(cam_from_world * world);
  }
  // The unit ray through a pixel, in world coordinates (nullopt when the
  // pixel does not unproject).
  std::optional<Eigen::Vector3d> WorldRay(const Eigen::Vector2d& pixel) const {
    const UnprojectResult r = camera.Unproject(pixel);
    if (!r.ok()) return std::nullopt;
    return cam_from_world.rotation.conjugate() * r.ray;
  }
};

}  // namespace pano4d
