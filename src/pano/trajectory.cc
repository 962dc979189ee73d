#include "src/pano/trajectory.h"

#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/json.h"

namespace pano4d {
namespace {

constexpr double kDegrees = M_PI / 180.0;
// The planar ablation's tan(angle) is unbounded at 90 degrees.
constexpr double kMaxPlanarAngle = 89.0 * kDegrees;

}  // namespace

void ExpansionGeometry::Check() const {
  if (directions < 1 || directions > kMaxDirections) {
    throw Error("expansion options", "directions", std::to_string(directions),
                "must be 1 to " + std::to_string(kMaxDirections));
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

RasterCamera RasterCameraFromJson(const nlohmann::json& j,
                                  const std::string& source) {
  if (!j.is_object()) {
    throw Error(source, "camera", j.dump(), "expected an object");
  }
  RasterCamera c;
  c.width = GetJson<int>(j, "width", source);
  c.height = GetJson<int>(j, "height", source);
  c.fx = static_cast<float>(GetJson<double>(j, "fx", source));
  c.fy = static_cast<float>(GetJson<double>(j, "fy", source));
  c.cx = static_cast<float>(GetJson<double>(j, "cx", source));
  c.cy = static_cast<float>(GetJson<double>(j, "cy", source));
  const auto q = GetJson<std::vector<double>>(j, "qvec", source);
  const auto t = GetJson<std::vector<double>>(j, "tvec", source);
  if (q.size() != 4 || t.size() != 3) {
    throw Error(source, "qvec/tvec", "",
                "expected 4 and 3 numbers (COLMAP's w, x, y, z and tvec)");
  }
  const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  if (!(c.width > 0 && c.height > 0 && c.fx > 0 && c.fy > 0) ||
      !(quat.norm() > 0.5 && quat.norm() < 2.0) ||
      !std::isfinite(t[0] + t[1] + t[2]) || !std::isfinite(c.cx + c.cy)) {
    throw Error(source, "camera", j.dump(),
                "needs a positive size and focal length, a unit quaternion "
                "and a finite translation");
  }
  c.rotation = quat.normalized().toRotationMatrix().cast<float>();
  c.translation = Eigen::Vector3d(t[0], t[1], t[2]).cast<float>();
  return c;
}

void VideoPathOptions::Check() const {
  if (frames < 1) {
    throw Error("video path", "frames", std::to_string(frames),
                "must be at least 1");
  }
  if (!(degrees > 0 && degrees <= 360)) {
    throw Error("video path", "degrees", std::to_string(degrees),
                "must be in (0, 360]");
  }
  if (num_times < 1 || time < 0 || time >= num_times) {
    throw Error("video path", "time", std::to_string(time),
                "must be in [0, " + std::to_string(num_times) + ")");
  }
}

std::vector<TimedCamera> VideoCameras(const VideoPathOptions& o,
                                      const RasterCamera& reference,
                                      const Eigen::Vector3d& center) {
  o.Check();
  const Eigen::Matrix3d r = reference.rotation.cast<double>();
  const Eigen::Vector3d right = r.row(0).transpose();
  const Eigen::Vector3d up = -r.row(1).transpose();
  const double span = o.degrees * kDegrees;
  std::vector<TimedCamera> out;
  for (int k = 0; k < o.frames; ++k) {
    const double u = o.frames > 1 ? static_cast<double>(k) / o.frames : 0.0;
    const int running = static_cast<int>(u * o.num_times);
    TimedCamera c;
    switch (o.path) {
      case VideoPath::kOrbit:
        c.camera = OrbitCamera(reference, center, up, span * u);
        c.time = running;
        break;
      case VideoPath::kSpiral: {
        const double phi = 2 * M_PI * u;
        c.camera = OrbitCamera(
            OrbitCamera(reference, center, up, span * std::sin(phi)), center,
            right, span * std::cos(phi));
        c.time = running;
        break;
      }
      case VideoPath::kBullet:
        // -swing/2 .. +swing/2 .. -swing/2 (a triangle wave over the video).
        c.camera = OrbitCamera(reference, center, up,
                               span * (0.5 - std::abs(2 * u - 1)));
        c.time = o.time;
        break;
    }
    out.push_back(c);
  }
  return out;
}

std::vector<TimedCamera> ReadCameraFile(
    const std::string& path, std::vector<nlohmann::json>* cameras_json) {
  const nlohmann::json j = ReadJson(path);
  const nlohmann::json& views =
      j.is_object() && j.contains("views") ? j.at("views") : j;
  if (!views.is_array() || views.empty()) {
    throw Error(path, "views", "",
                "expected a non-empty list of {\"camera\": {...}, \"t\": T} "
                "(the layout of trajectories.json)");
  }
  std::vector<TimedCamera> out;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const std::string source = path + " view " + std::to_string(i);
    if (!views[i].is_object() || !views[i].contains("camera")) {
      throw Error(source, "camera", "", "missing");
    }
    out.push_back({RasterCameraFromJson(views[i].at("camera"), source),
                   GetJsonOr<int>(views[i], "t", 0, source)});
    if (cameras_json != nullptr) cameras_json->push_back(views[i].at("camera"));
  }
  return out;
}

}  // namespace pano4d
