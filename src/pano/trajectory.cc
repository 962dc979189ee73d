#include "src/pano/trajectory.h"

#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "src/core/error.h"

namespace pano4d {
namespace {

constexpr double kDegrees = M_PI / 180.0;
// The planar ablation's tan(angle) is unbounded at 90 degrees.
constexpr double kMaxPlanarAngle = 89.0 * kDegrees;

}  // namespace

void ExpansionGeometry::Check() const {
  if (directions < 1) {
    throw Error("expansion options", "directions", std::to_string(directions),
                "must be at least 1");
  }
  if (steps < 1) {
    throw Error("expansion options", "steps", std::to_string(steps),
                "must be at least 1");
  }
  if (!(alpha_degrees > 0 && alpha_degrees * steps <= 180)) {
    throw Error("expansion options", "alpha",
                std::to_string(alpha_degrees) + " deg x " +
                    std::to_string(steps) + " steps",
                "the angle per step must be positive and the total at most "
                "180 degrees");
  }
  if (planar && alpha_degrees * steps * kDegrees > kMaxPlanarAngle) {
    throw Error("expansion options", "alpha",
                std::to_string(alpha_degrees * steps) + " deg",
                "planar expansion moves the camera by tan(angle): the total "
                "angle must stay below 89 degrees");
  }
}

Eigen::Vector3d ViewingDirection(const RasterCamera& camera) {
  return camera.rotation.row(2).transpose().cast<double>().normalized();
}

Eigen::Vector3d TangentDirection(const RasterCamera& reference, int m,
                                 int directions) {
  const Eigen::Vector3d right =
      reference.rotation.row(0).transpose().cast<double>().normalized();
  const Eigen::Vector3d up =
      -reference.rotation.row(1).transpose().cast<double>().normalized();
  const double a = 2 * M_PI * m / directions;
  return std::cos(a) * right + std::sin(a) * up;
}

Eigen::Vector3d RotationAxis(const Eigen::Vector3d& n,
                             const Eigen::Vector3d& d_m) {
  return n.cross(d_m).normalized();
}

Eigen::Vector3d ExpandedDirection(const Eigen::Vector3d& n,
                                  const Eigen::Vector3d& axis, double angle) {
  return n * std::cos(angle) + axis.cross(n) * std::sin(angle);
}

RasterCamera OrbitCamera(const RasterCamera& source,
                         const Eigen::Vector3d& center,
                         const Eigen::Vector3d& axis, double angle) {
  const Eigen::Matrix3d q = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
  const Eigen::Vector3d c = source.Center().cast<double>();
  const Eigen::Vector3d moved = center + q * (c - center);
  const Eigen::Matrix3d r = source.rotation.cast<double>() * q.transpose();
  RasterCamera out = source;
  out.rotation = r.cast<float>();
  out.translation = (-(r * moved)).cast<float>();
  return out;
}

RasterCamera PlanarCamera(const RasterCamera& source,
                          const Eigen::Vector3d& center,
                          const Eigen::Vector3d& d_m, double angle) {
  if (!(std::abs(angle) <= kMaxPlanarAngle)) {
    throw Error("planar expansion", "angle",
                std::to_string(angle / kDegrees) + " deg",
                "must be below 89 degrees");
  }
  const Eigen::Vector3d c = source.Center().cast<double>();
  const Eigen::Vector3d moved = c + (c - center).norm() * std::tan(angle) * d_m;
  RasterCamera out = source;
  out.translation = (-(source.rotation.cast<double>() * moved)).cast<float>();
  return out;
}

std::vector<ExpandedView> ExpansionViews(
    const ExpansionGeometry& geometry, const RasterCamera& reference,
    const Eigen::Vector3d& center, const std::vector<RasterCamera>& sources,
    const std::vector<int>& times, int e) {
  geometry.Check();
  if (sources.size() != times.size()) {
    throw Error("expansion views", "times", std::to_string(times.size()),
                "expected one per source camera (" +
                    std::to_string(sources.size()) + ")");
  }
  const Eigen::Vector3d n = ViewingDirection(reference);
  const double angle = e * geometry.alpha_degrees * kDegrees;
  std::vector<ExpandedView> views;
  views.reserve(geometry.directions * sources.size());
  for (int m = 0; m < geometry.directions; ++m) {
    const Eigen::Vector3d d =
        TangentDirection(reference, m, geometry.directions);
    const Eigen::Vector3d axis = RotationAxis(n, d);
    for (std::size_t i = 0; i < sources.size(); ++i) {
      ExpandedView v;
      v.m = m;
      v.e = e;
      v.t = times[i];
      v.camera = geometry.planar ? PlanarCamera(sources[i], center, d, angle)
                                 : OrbitCamera(sources[i], center, axis, angle);
      views.push_back(v);
    }
  }
  return views;
}

nlohmann::json CameraToJson(const RasterCamera& camera) {
  const Eigen::Quaterniond q(camera.rotation.cast<double>());
  return {{"width", camera.width},
          {"height", camera.height},
          {"fx", camera.fx},
          {"fy", camera.fy},
          {"cx", camera.cx},
          {"cy", camera.cy},
          {"qvec", {q.w(), q.x(), q.y(), q.z()}},
          {"tvec",
           {camera.translation.x(), camera.translation.y(),
            camera.translation.z()}}};
}

nlohmann::json ToJson(const ExpandedView& view) {
  return {{"m", view.m},
          {"e", view.e},
          {"t", view.t},
          {"source", view.name},
          {"camera", CameraToJson(view.camera)}};
}

}  // namespace pano4d
