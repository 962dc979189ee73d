#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pano4d {

// Rigid and similarity transforms.
//
// Quaternion convention, stated once for the whole project: COLMAP's qvec is
// (w, x, y, z) and describes the world-to-camera rotation; Eigen's
// Quaterniond(w, x, y, z) constructor takes the same order (its coeffs()
// storage is x, y, z, w, so never copy coeffs() into a qvec). A pose is held
// as `cam_from_world`: x_cam = R x_world + t, and the camera centre is
// c = -R^T t.

struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& rotation,
          const Eigen::Vector3d& translation)
      : rotation(rotation), translation(translation) {}

  // From COLMAP's qvec (w, x, y, z; need not be unit, is normalized) and
  // tvec. Throws pano4d::Error for a zero or non-finite qvec.
  static Rigid3d FromColmap(const Eigen::Vector4d& qvec_wxyz,
                            const Eigen::Vector3d& tvec);
  Eigen::Vector4d ColmapQvec() const;  // (w, x, y, z)

  Eigen::Vector3d operator*(const Eigen::Vector3d& point) const {
    return rotation * point + translation;
  }
  Rigid3d Inverse() const;
  Eigen::Matrix<double, 3, 4> ToMatrix() const;  // [R | t]
};

// (a * b) * x == a * (b * x)
Rigid3d operator*(const Rigid3d& a, const Rigid3d& b);

// The centre of a camera whose pose is cam_from_world: -R^T t.
Eigen::Vector3d CameraCenter(const Rigid3d& cam_from_world);

// x' = scale * R x + t.
struct Sim3d {
  double scale = 1.0;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Sim3d() = default;
  Sim3d(double scale, const Eigen::Quaterniond& rotation,
        const Eigen::Vector3d& translation)
      : scale(scale), rotation(rotation), translation(translation) {}

  // From a 4x4 matrix [sR t; 0 1], as Eigen::umeyama returns. Throws
  // pano4d::Error when the matrix is not a similarity (finite, positive
  // scale, orthogonal rotation with det +1).
  static Sim3d FromMatrix(const Eigen::Matrix4d& matrix);

  Eigen::Vector3d operator*(const Eigen::Vector3d& point) const {
    return scale * (rotation * point) + translation;
  }
  Sim3d Inverse() const;
  Eigen::Matrix4d ToMatrix() const;

  // A camera pose expressed in the transformed world: if this maps world A to
  // world B, cam_from_a becomes cam_from_b (same camera, centre moved by this,
  // translation scaled).
  Rigid3d TransformPose(const Rigid3d& cam_from_a) const;
};

Sim3d operator*(const Sim3d& a, const Sim3d& b);

}  // namespace pano4d
