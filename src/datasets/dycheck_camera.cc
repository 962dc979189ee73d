#include "src/datasets/dycheck_camera.h"

#include <cmath>
#include <sstream>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "src/core/error.h"
#include "src/core/json.h"

namespace pano4d {
namespace {

std::vector<double> FixedArray(const Json& json, const std::string& key,
                               std::size_t size, const std::string& source) {
  std::vector<double> values = GetJson<std::vector<double>>(json, key, source);
  if (values.size() != size) {
    throw Error(source, key, std::to_string(values.size()) + " values",
                "expected " + std::to_string(size));
  }
  for (const double v : values) {
    if (!std::isfinite(v))
      throw Error(source, key, JsonValueForMessage(json[key]),
                  "must be finite");
  }
  return values;
}

Eigen::Matrix3d Orientation(const Json& json, const std::string& source) {
  const Json rows = GetJson<Json>(json, "orientation", source);
  if (!rows.is_array() || rows.size() != 3) {
    throw Error(source, "orientation", JsonValueForMessage(rows),
                "expected a 3x3 array");
  }
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i) {
    const std::string field = "orientation[" + std::to_string(i) + "]";
    const std::vector<double> row =
        FixedArray(Json{{field, rows[i]}}, field, 3, source);
    r.row(i) = Eigen::Vector3d(row[0], row[1], row[2]);
  }
  const double error =
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(error <= kMaxOrientationError) || !(r.determinant() > 0)) {
    std::ostringstream text;
    text << "|R^T R - I| = " << error << ", det = " << r.determinant();
    throw Error(source, "orientation", text.str(), "is not a rotation matrix");
  }
  // Snap the float32 values to the nearest rotation.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

}  // namespace

PosedCamera DyCheckCameraFromJson(const Json& json, const std::string& source) {
  const double focal = GetJson<double>(json, "focal_length", source);
  const double aspect =
      GetJsonOr<double>(json, "pixel_aspect_ratio", 1.0, source);
  const double skew = GetJsonOr<double>(json, "skew", 0.0, source);
  const std::vector<double> pp = FixedArray(json, "principal_point", 2, source);
  const std::vector<int> size =
      GetJson<std::vector<int>>(json, "image_size", source);
  if (size.size() != 2) {
    throw Error(source, "image_size", std::to_string(size.size()) + " values",
                "expected [W, H]");
  }
  const std::vector<double> radial =
      json.contains("radial_distortion")
          ? FixedArray(json, "radial_distortion", 3, source)
          : std::vector<double>{0, 0, 0};
  const std::vector<double> tangential =
      json.contains("tangential_distortion")
          ? FixedArray(json, "tangential_distortion", 2, source)
          : std::vector<double>{0, 0};
  if (skew != 0.0) {
    throw Error(
        source, "skew", std::to_string(skew),
        "non-zero skew has no COLMAP camera model; undistort the images first");
  }

  PosedCamera out;
  Camera& camera = out.camera;
  camera.width = size[0];
  camera.height = size[1];
  const double fx = focal, fy = focal * aspect;
  const bool distorted = radial[0] != 0 || radial[1] != 0 || radial[2] != 0 ||
                         tangential[0] != 0 || tangential[1] != 0;
  if (!distorted) {
    camera.model_id = CameraModelId::kPinhole;
    camera.params = {fx, fy, pp[0], pp[1]};
  } else if (radial[2] == 0) {
    camera.model_id = CameraModelId::kOpenCV;
    camera.params = {fx,        fy,        pp[0],         pp[1],
                     radial[0], radial[1], tangential[0], tangential[1]};
  } else {
    camera.model_id = CameraModelId::kFullOpenCV;
    camera.params = {fx,        fy,        pp[0],         pp[1],
                     radial[0], radial[1], tangential[0], tangential[1],
                     radial[2], 0.0,       0.0,           0.0};
  }
  camera.Check(source);

  const Eigen::Matrix3d rotation = Orientation(json, source);
  const std::vector<double> position = FixedArray(json, "position", 3, source);
  const Eigen::Vector3d center(position[0], position[1], position[2]);
  out.cam_from_world =
      Rigid3d(Eigen::Quaterniond(rotation), -(rotation * center));
  return out;
}

Json DyCheckCameraToJson(const PosedCamera& posed) {
  const Camera& camera = posed.camera;
  camera.Check("camera");
  const std::vector<double>& p = camera.params;
  std::vector<double> radial = {0, 0, 0};
  std::vector<double> tangential = {0, 0};
  switch (camera.model_id) {
    case CameraModelId::kSimplePinhole:
    case CameraModelId::kPinhole:
      break;
    case CameraModelId::kSimpleRadial:
      radial[0] = p[3];
      break;
    case CameraModelId::kRadial:
      radial = {p[3], p[4], 0};
      break;
    case CameraModelId::kOpenCV:
      radial = {p[4], p[5], 0};
      tangential = {p[6], p[7]};
      break;
    case CameraModelId::kFullOpenCV:
      if (p[9] != 0 || p[10] != 0 || p[11] != 0) {
        throw Error("camera", "params", "k4..k6 non-zero",
                    "DyCheck cameras have no rational radial terms");
      }
      radial = {p[4], p[5], p[8]};
      tangential = {p[6], p[7]};
      break;
    default:
      throw Error(
          "camera", "model", std::string(camera.info().name),
          "DyCheck cameras support only pinhole and OpenCV-style distortion");
  }
  const Eigen::Matrix3d r = posed.cam_from_world.rotation.toRotationMatrix();
  Json orientation = Json::array();
  for (int i = 0; i < 3; ++i)
    orientation.push_back({r(i, 0), r(i, 1), r(i, 2)});
  const Eigen::Vector3d c = posed.Center();
  return Json{{"orientation", orientation},
              {"position", {c.x(), c.y(), c.z()}},
              {"focal_length", camera.focal_x()},
              {"pixel_aspect_ratio", camera.focal_y() / camera.focal_x()},
              {"principal_point", {camera.principal_x(), camera.principal_y()}},
              {"skew", 0.0},
              {"radial_distortion", radial},
              {"tangential_distortion", tangential},
              {"image_size", {camera.width, camera.height}}};
}

PosedCamera ReadDyCheckCamera(const std::filesystem::path& path) {
  return DyCheckCameraFromJson(ReadJson(path), path.string());
}

void WriteDyCheckCamera(const std::filesystem::path& path,
                        const PosedCamera& camera) {
  WriteJson(path, DyCheckCameraToJson(camera), 4);
}

}  // namespace pano4d
