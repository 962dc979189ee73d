#include "src/core/rigid.h"

#include <cmath>
#include <sstream>

#include "src/core/error.h"

namespace pano4d {
namespace {

// How far R^T R may drift from identity, per entry, for a matrix to count
// as a rotation: loose enough for single-precision inputs round-tripped
// through text, tight enough to reject a shear or reflection.
constexpr double kRotationTolerance = 1e-6;

std::string VectorText(const Eigen::VectorXd& v) {
  std::ostringstream out;
  out << v.transpose();
  return out.str();
}

}  // namespace

Rigid3d Rigid3d::FromColmap(const Eigen::Vector4d& qvec,
                            const Eigen::Vector3d& tvec) {
  // Scaled by its largest entry first: the norm of (1e300, 0, 0, 0)
  // overflows to inf, and dividing by it would give the zero quaternion.
  const double largest = qvec.cwiseAbs().maxCoeff();
  if (!qvec.allFinite() || !(largest > 0)) {
    throw Error("pose", "qvec", VectorText(qvec),
                "must be a finite, non-zero quaternion");
  }
  if (!tvec.allFinite())
    throw Error("pose", "tvec", VectorText(tvec), "must be finite");
  const Eigen::Vector4d q = (qvec / largest).normalized();
  return Rigid3d(Eigen::Quaterniond(q(0), q(1), q(2), q(3)), tvec);
}

Eigen::Vector4d Rigid3d::ColmapQvec() const {
  return {rotation.w(), rotation.x(), rotation.y(), rotation.z()};
}

Rigid3d Rigid3d::Inverse() const {
  const Eigen::Quaterniond inverse = rotation.conjugate();
  return Rigid3d(inverse, -(inverse * translation));
}

Eigen::Matrix<double, 3, 4> Rigid3d::ToMatrix() const {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = rotation.toRotationMatrix();
  m.col(3) = translation;
  return m;
}

Rigid3d operator*(const Rigid3d& a, const Rigid3d& b) {
  return Rigid3d((a.rotation * b.rotation).normalized(),
                 a.rotation * b.translation + a.translation);
}

Eigen::Vector3d CameraCenter(const Rigid3d& cam_from_world) {
  return -(cam_from_world.rotation.conjugate() * cam_from_world.translation);
}

Sim3d Sim3d::FromMatrix(const Eigen::Matrix4d& matrix) {
  std::ostringstream text;
  text << matrix.format(Eigen::IOFormat(Eigen::StreamPrecision, 0, " ", "; "));
  if (!matrix.allFinite())
    throw Error("sim3", "matrix", text.str(), "must be finite");
  const Eigen::Matrix3d sr = matrix.topLeftCorner<3, 3>();
  const double det = sr.determinant();
  if (!(det > 0)) {
    throw Error("sim3", "matrix", text.str(),
                "determinant must be positive (no reflection)");
  }
  const double scale = std::cbrt(det);
  const Eigen::Matrix3d r = sr / scale;
  if (!(r.transpose() * r)
           .isApprox(Eigen::Matrix3d::Identity(), kRotationTolerance) ||
      !matrix.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1))) {
    throw Error("sim3", "matrix", text.str(),
                "is not a similarity [sR t; 0 1]");
  }
  return Sim3d(scale, Eigen::Quaterniond(r).normalized(),
               matrix.topRightCorner<3, 1>());
}

Sim3d Sim3d::Inverse() const {
  const Eigen::Quaterniond inverse = rotation.conjugate();
  return Sim3d(1.0 / scale, inverse, -(inverse * translation) / scale);
}

Eigen::Matrix4d Sim3d::ToMatrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = scale * rotation.toRotationMatrix();
  m.topRightCorner<3, 1>() = translation;
  return m;
}

Rigid3d Sim3d::TransformPose(const Rigid3d& cam_from_a) const {
  // x_cam = R_c x_a + t_c and x_a = (R^T (x_b - t)) / s give
  // x_cam = R_c R^T x_b / s + (t_c - R_c R^T t / s); a camera frame keeps its
  // metric only up to the scale, so multiply through by s.
  const Eigen::Quaterniond rotation_b =
      (cam_from_a.rotation * rotation.conjugate()).normalized();
  return Rigid3d(rotation_b,
                 scale * cam_from_a.translation - rotation_b * translation);
}

Sim3d operator*(const Sim3d& a, const Sim3d& b) {
  return Sim3d(a.scale * b.scale, (a.rotation * b.rotation).normalized(),
               a.scale * (a.rotation * b.translation) + a.translation);
}

}  // namespace pano4d
