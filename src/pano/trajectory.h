#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

#include "src/render/gaussians.h"

namespace pano4d {

// The expansion's geometry (DESIGN.md, eqs. dir1 and dir2; paper defaults).
// One direction a degree about the view axis: more are not distinct views,
// and each costs a warp and a prior call per step and source frame.
inline constexpr int kMaxDirections = 360;

struct ExpansionGeometry {
  int directions = 8;           // M
  int steps = 6;                // E
  double alpha_degrees = 15.0;  // angle per step
  // Ablation: translate cameras in the tangent plane instead of orbiting
  // them about the panorama's centre (see PlanarCamera).
  bool planar = false;

  void Check() const;  // throws pano4d::Error naming the field
};

// eq. dir1: d_m = cos(2 pi m / M) right + sin(2 pi m / M) up, in world
// coordinates, with right (+x) and up (-y) the reference camera's axes:
// unit and orthogonal to its viewing vector n.
Eigen::Vector3d TangentDirection(const RasterCamera& reference, int m,
                                 int directions);
// The viewing vector n of a camera (its +z axis) in world coordinates.
Eigen::Vector3d ViewingDirection(const RasterCamera& camera);
// a_m = n x d_m (unit): the axis step e rotates about.
Eigen::Vector3d RotationAxis(const Eigen::Vector3d& n,
                             const Eigen::Vector3d& d_m);
// eq. dir2: s = n cos(angle) + (a_m x n) sin(angle).
Eigen::Vector3d ExpandedDirection(const Eigen::Vector3d& n,
                                  const Eigen::Vector3d& axis, double angle);

// The expanded camera: `source` orbited about `center` by `angle` radians
// about `axis`: Q = AngleAxis(angle, axis), c' = center + Q (c - center),
// cam_from_world rotation R' = R Q^T. angle 0 gives `source` back.
RasterCamera OrbitCamera(const RasterCamera& source,
                         const Eigen::Vector3d& center,
                         const Eigen::Vector3d& axis, double angle);
// The planar ablation: the same orientation, the centre moved along d_m by
// |c - center| tan(angle), so that the panorama's centre shifts in the view
// by the same angle as it would in the orbit. angle must be below 90 deg.
RasterCamera PlanarCamera(const RasterCamera& source,
                          const Eigen::Vector3d& center,
                          const Eigen::Vector3d& d_m, double angle);

// One camera of the expansion: direction m, step e (angle e alpha), frame
// time t, orbiting the source camera of that time.
struct ExpandedView {
  int m = 0, e = 0, t = 0;
  RasterCamera camera;
  std::string name;  // the source frame's, when known (file names)
};

// The views of step e (1..E) for every direction and the given source
// cameras (one per time, `times` alongside). The directions come from
// `reference` (the first frame's camera), as in the paper, so that every
// time moves the same way.
std::vector<ExpandedView> ExpansionViews(
    const ExpansionGeometry& geometry, const RasterCamera& reference,
    const Eigen::Vector3d& center, const std::vector<RasterCamera>& sources,
    const std::vector<int>& times, int e);

// {"m", "e", "t", "camera": {width, height, fx, fy, cx, cy, qvec, tvec}}
// with COLMAP's qvec (w, x, y, z) and tvec of cam_from_world.
nlohmann::json ToJson(const ExpandedView& view);
nlohmann::json CameraToJson(const RasterCamera& camera);
// The inverse of CameraToJson. Throws pano4d::Error naming `source` and the
// field that is missing, of the wrong type or out of range.
RasterCamera RasterCameraFromJson(const nlohmann::json& json,
                                  const std::string& source);

// Novel-view videos (`pano4d render`): cameras moved about `center` from
// `reference` (its intrinsics kept), each with the time it shows.
struct TimedCamera {
  RasterCamera camera;
  int time = 0;
};
enum class VideoPath {
  kOrbit,   // about the up axis through the centre, time running
  kSpiral,  // a circle of `degrees` around the reference view, time running
  kBullet,  // time frozen, swinging +-degrees/2 about the up axis and back
};
struct VideoPathOptions {
  VideoPath path = VideoPath::kOrbit;
  int frames = 60;
  double degrees =
      360.0;           // orbit: the arc; spiral: the radius; bullet: the swing
  int num_times = 1;   // times run 0..num_times-1 over the video
  int time = 0;        // bullet time
  void Check() const;  // throws pano4d::Error naming the field
};
// Up is the reference camera's -y. Frame 0 of orbit and spiral is the
// reference camera rotated by 0 (orbit) or `degrees` about the right axis
// (spiral); every camera keeps its distance to `center` and looks at it as
// the reference does.
std::vector<TimedCamera> VideoCameras(const VideoPathOptions& options,
                                      const RasterCamera& reference,
                                      const Eigen::Vector3d& center);
// A camera file: {"views": [{"camera": {...}, "t": T}, ...]} (the layout of
// trajectories.json) or the list alone. Throws pano4d::Error naming the file.
// `cameras_json`, when given, receives each view's "camera" object as read:
// written back unchanged, it renders the same cameras bit for bit (a float
// rotation does not survive CameraToJson's quaternion exactly).
std::vector<TimedCamera> ReadCameraFile(
    const std::string& path,
    std::vector<nlohmann::json>* cameras_json = nullptr);

}  // namespace pano4d
