#include "src/core/camera.h"

#include <cmath>
#include <limits>

#include <Eigen/LU>
#include <unsupported/Eigen/AutoDiff>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

using Dual = Eigen::AutoDiffScalar<Eigen::Vector2d>;

inline double Value(double x) { return x; }
inline double Value(const Dual& x) { return x.value(); }

// Math on both number types. Eigen's AutoDiff has no atan, and explicit
// overloads avoid relying on argument-dependent lookup into Eigen.
inline double Sqrt(double x) { return std::sqrt(x); }
inline double Atan(double x) { return std::atan(x); }
inline Dual Sqrt(const Dual& x) {
  const double s = std::sqrt(x.value());
  return Dual(s, x.derivatives() * (0.5 / s));
}
inline Dual Atan(const Dual& x) {
  return Dual(std::atan(x.value()),
              x.derivatives() / (1.0 + x.value() * x.value()));
}

// Below this radius off the optical axis the fisheye angle map is the
// identity to machine precision (atan(r)/r = 1 - r^2/3); COLMAP uses the same
// cut. Comparing r^2 also keeps the derivative of sqrt finite at the axis.
constexpr double kFisheyeAxisEpsilon = std::numeric_limits<double>::epsilon();

// Newton's method for undistortion. It stops when the residual in
// normalized units is at the floating-point floor, and accepts the result
// when the residual is below kUndistortTolerance (both relative to
// 1 + |target|). At a focal length of 1000 px the acceptance bound is 1e-9 px.
constexpr int kMaxUndistortIterations = 100;
constexpr int kMaxStepHalvings = 30;
constexpr double kUndistortStopTolerance =
    4 * std::numeric_limits<double>::epsilon();
constexpr double kUndistortTolerance = 1e-12;

// A fisheye ray must stay strictly in front of the camera: COLMAP's fisheye
// models divide by z, so 90 degrees off-axis has no pixel.
constexpr double kMaxFisheyeAngle = M_PI / 2 - 1e-9;

const std::vector<CameraModelInfo> kModels = {
    {CameraModelId::kSimplePinhole, "SIMPLE_PINHOLE", 3, "f, cx, cy", true,
     false},
    {CameraModelId::kPinhole, "PINHOLE", 4, "fx, fy, cx, cy", false, false},
    {CameraModelId::kSimpleRadial, "SIMPLE_RADIAL", 4, "f, cx, cy, k", true,
     false},
    {CameraModelId::kRadial, "RADIAL", 5, "f, cx, cy, k1, k2", true, false},
    {CameraModelId::kOpenCV, "OPENCV", 8, "fx, fy, cx, cy, k1, k2, p1, p2",
     false, false},
    {CameraModelId::kOpenCVFisheye, "OPENCV_FISHEYE", 8,
     "fx, fy, cx, cy, k1, k2, k3, k4", false, true},
    {CameraModelId::kFullOpenCV, "FULL_OPENCV", 12,
     "fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6", false, false},
    {CameraModelId::kFOV, "FOV", 5, "fx, fy, cx, cy, omega", false, false},
    {CameraModelId::kSimpleRadialFisheye, "SIMPLE_RADIAL_FISHEYE", 4,
     "f, cx, cy, k", true, true},
    {CameraModelId::kRadialFisheye, "RADIAL_FISHEYE", 5, "f, cx, cy, k1, k2",
     true, true},
    {CameraModelId::kThinPrismFisheye, "THIN_PRISM_FISHEYE", 12,
     "fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1", false, true},
};

// Fisheye models first map normalized (u, v) to equidistant angle coordinates
// (a, b) = theta / r * (u, v), theta = atan(r) the angle off the axis; their
// polynomial distortion then acts on (a, b). This is COLMAP's formula
// rewritten (u * thetad / r = a * thetad / theta), and it lets undistortion
// work in angle space, which stays well conditioned up to 90 degrees.
template <typename T>
void AngleFromNormalized(const T& u, const T& v, T* a, T* b) {
  const T r2 = u * u + v * v;
  if (Value(r2) > kFisheyeAxisEpsilon * kFisheyeAxisEpsilon) {
    const T r = Sqrt(r2);
    const T scale = Atan(r) / r;
    *a = u * scale;
    *b = v * scale;
  } else {
    *a = u;
    *b = v;
  }
}

// The FOV model's radial factor at r^2 for field of view omega, with
// COLMAP's series expansions near omega = 0 and r = 0, where the closed form
// is 0/0.
template <typename T>
T FovFactor(double omega, const T& r2) {
  const double omega2 = omega * omega;
  constexpr double kFovSeriesEpsilon = 1e-4;
  if (omega2 < kFovSeriesEpsilon)
    return (omega2 * r2) / 3.0 - omega2 / 12.0 + 1.0;
  if (Value(r2) < kFovSeriesEpsilon) {
    const double tan_half = std::tan(omega / 2);
    return (-2.0 * tan_half * (4.0 * r2 * tan_half * tan_half - 3.0)) /
           (3.0 * omega);
  }
  const T r = Sqrt(r2);
  return Atan(T(r * (2.0 * std::tan(omega / 2)))) / (r * omega);
}

// The distortion proper, COLMAP's formulas: maps (u, v) (normalized, or angle
// coordinates for fisheye models) to distorted coordinates. `k` points at the
// model's extra parameters.
template <typename T>
void Distort(CameraModelId id, const double* k, const T& u, const T& v, T* ud,
             T* vd) {
  const T u2 = u * u;
  const T v2 = v * v;
  const T uv = u * v;
  const T r2 = u2 + v2;
  switch (id) {
    case CameraModelId::kSimplePinhole:
    case CameraModelId::kPinhole:
      *ud = u;
      *vd = v;
      return;
    case CameraModelId::kSimpleRadial: {
      const T radial = k[0] * r2;
      *ud = u + u * radial;
      *vd = v + v * radial;
      return;
    }
    case CameraModelId::kRadial: {
      const T radial = k[0] * r2 + k[1] * r2 * r2;
      *ud = u + u * radial;
      *vd = v + v * radial;
      return;
    }
    case CameraModelId::kOpenCV: {
      const T radial = k[0] * r2 + k[1] * r2 * r2;
      *ud = u + u * radial + 2.0 * k[2] * uv + k[3] * (r2 + 2.0 * u2);
      *vd = v + v * radial + 2.0 * k[3] * uv + k[2] * (r2 + 2.0 * v2);
      return;
    }
    case CameraModelId::kFullOpenCV: {
      const T r4 = r2 * r2;
      const T r6 = r4 * r2;
      const T radial = (1.0 + k[0] * r2 + k[1] * r4 + k[4] * r6) /
                       (1.0 + k[5] * r2 + k[6] * r4 + k[7] * r6);
      *ud = u * radial + 2.0 * k[2] * uv + k[3] * (r2 + 2.0 * u2);
      *vd = v * radial + 2.0 * k[3] * uv + k[2] * (r2 + 2.0 * v2);
      return;
    }
    case CameraModelId::kOpenCVFisheye: {
      const T t4 = r2 * r2;  // r2 is theta^2 in angle coordinates
      const T scale =
          1.0 + k[0] * r2 + k[1] * t4 + k[2] * t4 * r2 + k[3] * t4 * t4;
      *ud = u * scale;
      *vd = v * scale;
      return;
    }
    case CameraModelId::kSimpleRadialFisheye: {
      const T scale = 1.0 + k[0] * r2;
      *ud = u * scale;
      *vd = v * scale;
      return;
    }
    case CameraModelId::kRadialFisheye: {
      const T scale = 1.0 + k[0] * r2 + k[1] * r2 * r2;
      *ud = u * scale;
      *vd = v * scale;
      return;
    }
    case CameraModelId::kThinPrismFisheye: {
      const T r4 = r2 * r2;
      const T radial = k[0] * r2 + k[1] * r4 + k[4] * r4 * r2 + k[5] * r4 * r4;
      *ud =
          u + u * radial + 2.0 * k[2] * uv + k[3] * (r2 + 2.0 * u2) + k[6] * r2;
      *vd =
          v + v * radial + 2.0 * k[3] * uv + k[2] * (r2 + 2.0 * v2) + k[7] * r2;
      return;
    }
    case CameraModelId::kFOV: {
      const T factor = FovFactor(k[0], r2);
      *ud = u * factor;
      *vd = v * factor;
      return;
    }
  }
  *ud = u;
  *vd = v;
}

// Normalized -> distorted normalized, the whole model short of focal length
// and principal point.
template <typename T>
void DistortNormalized(CameraModelId id, const double* k, bool fisheye,
                       const T& u, const T& v, T* ud, T* vd) {
  if (fisheye) {
    T a, b;
    AngleFromNormalized(u, v, &a, &b);
    Distort(id, k, a, b, ud, vd);
  } else {
    Distort(id, k, u, v, ud, vd);
  }
}

int ExtraOffset(const CameraModelInfo& info) {
  return info.single_focal ? 3 : 4;
}

// Value and 2x2 Jacobian of a map evaluated with dual numbers.
template <typename F>
Eigen::Vector2d EvaluateWithJacobian(const F& map, const Eigen::Vector2d& x,
                                     Eigen::Matrix2d* jacobian) {
  const Dual u(x.x(), 2, 0);
  const Dual v(x.y(), 2, 1);
  Dual ud, vd;
  map(u, v, &ud, &vd);
  // A branch that returns a constant leaves the derivative vector empty.
  auto row = [](const Dual& d) -> Eigen::Vector2d {
    return d.derivatives().size() == 2 ? Eigen::Vector2d(d.derivatives())
                                       : Eigen::Vector2d::Zero();
  };
  jacobian->row(0) = row(ud).transpose();
  jacobian->row(1) = row(vd).transpose();
  return Eigen::Vector2d(ud.value(), vd.value());
}

}  // namespace

const std::vector<CameraModelInfo>& AllCameraModels() { return kModels; }

const CameraModelInfo& GetCameraModelInfo(CameraModelId id) {
  const int index = static_cast<int>(id);
  if (index < 0 || index >= static_cast<int>(kModels.size())) {
    throw Error("camera", "model_id", std::to_string(index),
                "not a COLMAP camera model id");
  }
  return kModels[index];
}

std::optional<CameraModelId> CameraModelFromName(std::string_view name) {
  for (const CameraModelInfo& info : kModels) {
    if (info.name == name) return info.id;
  }
  return std::nullopt;
}

std::optional<CameraModelId> CameraModelFromId(int id) {
  if (id < 0 || id >= static_cast<int>(kModels.size())) return std::nullopt;
  return static_cast<CameraModelId>(id);
}

std::string_view ToString(UnprojectStatus status) {
  switch (status) {
    case UnprojectStatus::kOk:
      return "ok";
    case UnprojectStatus::kInvalidInput:
      return "pixel is not finite";
    case UnprojectStatus::kOutsideDomain:
      return "no ray maps to this pixel (outside the distortion model's valid "
             "domain)";
    case UnprojectStatus::kNotConverged:
      return "iterative undistortion did not converge";
  }
  return "unknown";
}

void Camera::Check(const std::string& source) const {
  const int id = static_cast<int>(model_id);
  if (!CameraModelFromId(id)) {
    throw Error(source, "model", std::to_string(id),
                "not a COLMAP camera model id");
  }
  if (width <= 0)
    throw Error(source, "width", std::to_string(width), "must be positive");
  if (height <= 0)
    throw Error(source, "height", std::to_string(height), "must be positive");
  const CameraModelInfo& model = info();
  if (static_cast<int>(params.size()) != model.num_params) {
    throw Error(source, "params", std::to_string(params.size()) + " values",
                "model " + std::string(model.name) + " expects " +
                    std::to_string(model.num_params) + " (" +
                    std::string(model.params_info) + ")");
  }
  for (std::size_t i = 0; i < params.size(); ++i) {
    if (!std::isfinite(params[i])) {
      throw Error(source, "params[" + std::to_string(i) + "]",
                  std::to_string(params[i]), "must be finite");
    }
  }
  if (!(focal_x() > 0) || !(focal_y() > 0)) {
    throw Error(source, "params", "focal " + std::to_string(focal_x()),
                "focal lengths must be positive");
  }
}

double Camera::focal_y() const {
  return info().single_focal ? params[0] : params[1];
}
double Camera::principal_x() const {
  return params[info().single_focal ? 1 : 2];
}
double Camera::principal_y() const {
  return params[info().single_focal ? 2 : 3];
}

bool Camera::HasDistortion() const {
  return model_id != CameraModelId::kSimplePinhole &&
         model_id != CameraModelId::kPinhole;
}

Eigen::Vector2d Camera::PixelFromNormalized(
    const Eigen::Vector2d& normalized) const {
  const CameraModelInfo& model = info();
  double xd, yd;
  DistortNormalized(model_id, params.data() + ExtraOffset(model), model.fisheye,
                    normalized.x(), normalized.y(), &xd, &yd);
  return {focal_x() * xd + principal_x(), focal_y() * yd + principal_y()};
}

Eigen::Matrix2d Camera::JacobianNormalized(
    const Eigen::Vector2d& normalized) const {
  const CameraModelInfo& model = info();
  const double* k = params.data() + ExtraOffset(model);
  Eigen::Matrix2d jacobian;
  EvaluateWithJacobian(
      [&](const Dual& u, const Dual& v, Dual* ud, Dual* vd) {
        DistortNormalized(model_id, k, model.fisheye, u, v, ud, vd);
      },
      normalized, &jacobian);
  jacobian.row(0) *= focal_x();
  jacobian.row(1) *= focal_y();
  return jacobian;
}

Eigen::Matrix<double, 2, 3> Camera::JacobianPointCam(
    const Eigen::Vector3d& point_cam) const {
  const double inv_z = 1.0 / point_cam.z();
  const Eigen::Vector2d normalized = point_cam.head<2>() * inv_z;
  Eigen::Matrix<double, 2, 3> d_normalized;
  d_normalized << inv_z, 0, -normalized.x() * inv_z,  //
      0, inv_z, -normalized.y() * inv_z;
  return JacobianNormalized(normalized) * d_normalized;
}

std::optional<Eigen::Vector2d> Camera::Project(
    const Eigen::Vector3d& point_cam) const {
  if (!(point_cam.z() > kMinProjectDepth) || !point_cam.allFinite())
    return std::nullopt;
  const Eigen::Vector2d normalized = point_cam.head<2>() / point_cam.z();
  if (HasDistortion() && !(JacobianNormalized(normalized).determinant() > 0)) {
    return std::nullopt;
  }
  const Eigen::Vector2d pixel = PixelFromNormalized(normalized);
  if (!pixel.allFinite()) return std::nullopt;
  return pixel;
}

namespace {

// The normalized coordinates and unit ray of the undistorted point x
// (angle coordinates for a fisheye model); false beyond the fisheye
// models' domain.
bool SetRay(bool fisheye, const Eigen::Vector2d& x, UnprojectResult* result) {
  if (!fisheye) {
    result->normalized = x;
    result->ray = Eigen::Vector3d(x.x(), x.y(), 1.0).normalized();
    return true;
  }
  const double theta = x.norm();
  if (theta >= kMaxFisheyeAngle) return false;
  const Eigen::Vector2d axis = theta > kFisheyeAxisEpsilon
                                   ? Eigen::Vector2d(x / theta)
                                   : Eigen::Vector2d::Zero();
  const double tan_over_theta =
      theta > kFisheyeAxisEpsilon ? std::tan(theta) / theta : 1.0;
  result->normalized = x * tan_over_theta;
  result->ray = Eigen::Vector3d(std::sin(theta) * axis.x(),
                                std::sin(theta) * axis.y(), std::cos(theta));
  return true;
}

}  // namespace

UnprojectResult Camera::Unproject(const Eigen::Vector2d& pixel) const {
  UnprojectResult result;
  if (!pixel.allFinite()) return result;  // kInvalidInput
  const CameraModelInfo& model = info();
  const Eigen::Vector2d target((pixel.x() - principal_x()) / focal_x(),
                               (pixel.y() - principal_y()) / focal_y());
  if (!HasDistortion()) {
    result.normalized = target;
    result.ray = Eigen::Vector3d(target.x(), target.y(), 1.0).normalized();
    result.status = UnprojectStatus::kOk;
    return result;
  }

  const double* k = params.data() + ExtraOffset(model);
  const auto distort = [&](const auto& u, const auto& v, auto* ud, auto* vd) {
    Distort(model_id, k, u, v, ud, vd);
  };
  const auto residual_at = [&](const Eigen::Vector2d& x) {
    double xd, yd;
    distort(x.x(), x.y(), &xd, &yd);
    return (Eigen::Vector2d(xd, yd) - target).norm();
  };

  // Solve Distort(x) = target for x: normalized coordinates, or angle
  // coordinates for fisheye models. The undistorted point starts at the
  // distorted one; steps are halved until the residual decreases.
  const double scale = 1.0 + target.norm();
  Eigen::Vector2d x = target;
  Eigen::Matrix2d jacobian;
  double residual = 0.0;
  for (result.iterations = 0;; ++result.iterations) {
    const Eigen::Vector2d f = EvaluateWithJacobian(distort, x, &jacobian);
    residual = (f - target).norm();
    if (!std::isfinite(residual) ||
        residual <= kUndistortStopTolerance * scale ||
        result.iterations == kMaxUndistortIterations ||
        !(jacobian.determinant() > 0)) {
      break;
    }
    const Eigen::Vector2d step = jacobian.inverse() * (f - target);
    double t = 1.0;
    bool improved = false;
    for (int h = 0; h <= kMaxStepHalvings && !improved; ++h, t *= 0.5) {
      const Eigen::Vector2d candidate = x - t * step;
      if (residual_at(candidate) < residual) {
        x = candidate;
        improved = true;
      }
    }
    if (!improved) break;  // at the floating-point floor, or stuck
  }

  // Here `jacobian` and `residual` belong to the final x.
  const auto fail = [&result](UnprojectStatus status) {
    result.status = status;
    return result;
  };
  if (!std::isfinite(residual)) return fail(UnprojectStatus::kNotConverged);
  if (!(jacobian.determinant() > 0))
    return fail(UnprojectStatus::kOutsideDomain);
  if (residual > kUndistortTolerance * scale)
    return fail(UnprojectStatus::kNotConverged);

  if (!SetRay(model.fisheye, x, &result))
    return fail(UnprojectStatus::kOutsideDomain);
  result.residual_px = (PixelFromNormalized(result.normalized) - pixel).norm();
  result.status = UnprojectStatus::kOk;
  return result;
}

Camera Camera::Rescaled(int new_width, int new_height) const {
  Check();
  if (new_width <= 0 || new_height <= 0) {
    throw Error("camera", "size", SizeText(new_width, new_height),
                "rescaled size must be positive");
  }
  const double sx = static_cast<double>(new_width) / width;
  const double sy = static_cast<double>(new_height) / height;
  Camera out = *this;
  out.width = new_width;
  out.height = new_height;
  if (info().single_focal) {
    out.params[0] *= 0.5 * (sx + sy);
    out.params[1] *= sx;
    out.params[2] *= sy;
  } else {
    out.params[0] *= sx;
    out.params[1] *= sy;
    out.params[2] *= sx;
    out.params[3] *= sy;
  }
  return out;
}

nlohmann::json CameraToJson(const Camera& camera) {
  return Json{{"model", std::string(camera.info().name)},
              {"width", camera.width},
              {"height", camera.height},
              {"params", camera.params}};
}

Camera CameraFromJson(const nlohmann::json& json, const std::string& source) {
  Camera camera;
  const std::string name = GetJson<std::string>(json, "model", source);
  const std::optional<CameraModelId> id = CameraModelFromName(name);
  if (!id) {
    std::string known;
    for (const CameraModelInfo& info : kModels) {
      known += (known.empty() ? "" : ", ") + std::string(info.name);
    }
    throw Error(source, "model", "\"" + name + "\"",
                "unknown camera model; use one of " + known);
  }
  camera.model_id = *id;
  camera.width = GetJson<int>(json, "width", source);
  camera.height = GetJson<int>(json, "height", source);
  camera.params = GetJson<std::vector<double>>(json, "params", source);
  camera.Check(source);
  return camera;
}

Camera AsPinhole(const Camera& camera, const std::string& source) {
  const CameraModelId id = camera.model_id;
  if (id == CameraModelId::kSimplePinhole || id == CameraModelId::kPinhole)
    return camera;
  const bool single = GetCameraModelInfo(id).single_focal;
  const std::size_t intrinsic = single ? 3 : 4;
  for (std::size_t i = intrinsic; i < camera.params.size(); ++i) {
    if (camera.params[i] != 0.0) {
      throw Error(source, "camera", std::string(GetCameraModelInfo(id).name),
                  "has lens distortion; pano4d fits pinhole cameras "
                  "(undistort the frames first, e.g. `pano4d sfm` runs colmap "
                  "image_undistorter)");
    }
  }
  Camera out = camera;
  out.model_id = CameraModelId::kPinhole;
  out.params = single ? std::vector<double>{camera.params[0], camera.params[0],
                                            camera.params[1], camera.params[2]}
                      : std::vector<double>(camera.params.begin(),
                                            camera.params.begin() + 4);
  return out;
}

}  // namespace pano4d
