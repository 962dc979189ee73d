#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

namespace pano4d {

// Camera models with COLMAP's names, numeric ids and parameter orders, so a
// camera read from cameras.bin/txt means the same thing here.
//
// Conventions (DESIGN.md): camera frame x right, y down, z forward (OpenCV).
// Pixel coordinates are continuous with the image's top-left corner at (0, 0),
// so pixel (i, j) has its centre at (i + 0.5, j + 0.5) as in COLMAP.
// "Normalized" coordinates are (x/z, y/z) of a camera-frame point, before
// distortion.
enum class CameraModelId : int {
  kSimplePinhole = 0,        // f, cx, cy
  kPinhole = 1,              // fx, fy, cx, cy
  kSimpleRadial = 2,         // f, cx, cy, k
  kRadial = 3,               // f, cx, cy, k1, k2
  kOpenCV = 4,               // fx, fy, cx, cy, k1, k2, p1, p2
  kOpenCVFisheye = 5,        // fx, fy, cx, cy, k1, k2, k3, k4
  kFullOpenCV = 6,           // fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6
  kFOV = 7,                  // fx, fy, cx, cy, omega
  kSimpleRadialFisheye = 8,  // f, cx, cy, k
  kRadialFisheye = 9,        // f, cx, cy, k1, k2
  kThinPrismFisheye = 10,    // fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1
};

struct CameraModelInfo {
  CameraModelId id;
  std::string_view name;  // COLMAP's name, e.g. "OPENCV"
  int num_params;
  std::string_view
      params_info;    // COLMAP's parameter list, e.g. "fx, fy, cx, cy, ..."
  bool single_focal;  // one f for both axes
  bool fisheye;       // distortion acts on the angle off the axis
};

// Every model, ordered by id.
const std::vector<CameraModelInfo>& AllCameraModels();
const CameraModelInfo& GetCameraModelInfo(CameraModelId id);
// nullopt for names/ids COLMAP does not define.
std::optional<CameraModelId> CameraModelFromName(std::string_view name);
std::optional<CameraModelId> CameraModelFromId(int id);

// Why an unprojection failed; kOk when it did not.
enum class UnprojectStatus {
  kOk,
  kInvalidInput,   // the pixel is NaN or infinite
  kOutsideDomain,  // no ray maps there: beyond the fold of a barrel
                   // distortion, or 90 degrees or more off-axis for fisheye
  kNotConverged,   // the iterative undistortion did not reach its tolerance
};
std::string_view ToString(UnprojectStatus status);

struct UnprojectResult {
  UnprojectStatus status = UnprojectStatus::kInvalidInput;
  Eigen::Vector2d normalized = Eigen::Vector2d::Zero();  // (x/z, y/z)
  Eigen::Vector3d ray = Eigen::Vector3d::Zero();         // unit, z > 0
  int iterations = 0;
  double residual_px = 0.0;  // |Project(ray) - pixel| at the end, in pixels

  bool ok() const { return status == UnprojectStatus::kOk; }
};

// The accessors and projections below assume a camera that passed Check()
// (readers such as CameraFromJson call it).
struct Camera {
  CameraModelId model_id = CameraModelId::kPinhole;
  int width = 0;
  int height = 0;
  std::vector<double> params;  // in COLMAP's order for model_id

  // Throws pano4d::Error naming `source` and the offending field when the
  // size is not positive, the parameter count does not match the model, a
  // parameter is not finite, or a focal length is not positive.
  void Check(const std::string& source = "camera") const;

  const CameraModelInfo& info() const { return GetCameraModelInfo(model_id); }
  double focal_x() const { return params[0]; }
  double focal_y() const;
  double principal_x() const;
  double principal_y() const;
  bool HasDistortion() const;

  // Camera-frame point to pixel. nullopt when the point is not in front of
  // the camera (z <= kMinProjectDepth) or lies where the distortion model
  // folds back on itself (the Jacobian of distortion has det <= 0), since a
  // pixel computed there would be a false image of the point.
  std::optional<Eigen::Vector2d> Project(
      const Eigen::Vector3d& point_cam) const;

  // Normalized to pixel, without the validity checks of Project.
  Eigen::Vector2d PixelFromNormalized(const Eigen::Vector2d& normalized) const;

  // d pixel / d normalized (2x2), and d pixel / d point_cam (2x3).
  Eigen::Matrix2d JacobianNormalized(const Eigen::Vector2d& normalized) const;
  Eigen::Matrix<double, 2, 3> JacobianPointCam(
      const Eigen::Vector3d& point_cam) const;

  // Pixel to normalized coordinates and unit ray, inverting the distortion by
  // Newton's method. A pixel with no valid preimage, or whose iteration does
  // not converge to kUndistortTolerance, comes back with a status that says
  // so, never as a silently wrong ray.
  UnprojectResult Unproject(const Eigen::Vector2d& pixel) const;

  // The same camera for an image resized to new_width x new_height (e.g.
  // DyCheck's 2x folders): focal lengths and principal point scale with the
  // image; distortion, which acts on normalized coordinates, does not.
  Camera Rescaled(int new_width, int new_height) const;
};

// Points closer than this to the camera plane do not project: their pixel
// coordinates would overflow or flip sign.
inline constexpr double kMinProjectDepth = 1e-9;

// `camera` as a pinhole camera: SIMPLE_PINHOLE and PINHOLE as they are, any
// other model as PINHOLE (fx, fy, cx, cy) when all its distortion
// parameters are 0.
// Throws pano4d::Error naming `source` when the camera has distortion:
// pano4d fits pinhole cameras, so the frames must be undistorted first.
Camera AsPinhole(const Camera& camera, const std::string& source);

// JSON form: {"model": "OPENCV", "width": W, "height": H, "params": [...]}.
nlohmann::json CameraToJson(const Camera& camera);
// Parses and Check()s; errors name `source` and the field.
Camera CameraFromJson(const nlohmann::json& json, const std::string& source);

}  // namespace pano4d
