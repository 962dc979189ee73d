#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "src/render/rasterizer.h"

namespace pano4d {

// A Gaussian's rotation from its raw (w, x, y, z) quaternion, normalised on
// use; a quaternion shorter than kMinQuaternionNorm stands for the identity.
template <typename T>
struct UnitQuaternion {
  explicit UnitQuaternion(const T* raw)
      : raw(raw[0], raw[1], raw[2], raw[3]),
        norm(this->raw.norm()),
        valid(norm > T(kMinQuaternionNorm)),
        q(valid ? Eigen::Matrix<T, 4, 1>(this->raw / norm)
                : Eigen::Matrix<T, 4, 1>(1, 0, 0, 0)) {}

  Eigen::Matrix<T, 3, 3> Rotation() const {
    return Eigen::Quaternion<T>(q(0), q(1), q(2), q(3)).toRotationMatrix();
  }

  // The gradient with respect to the raw quaternion, given the gradient
  // d_rot with respect to the rotation matrix; zero when the identity stood
  // in (it does not depend on the raw values).
  Eigen::Matrix<T, 4, 1> Backward(const Eigen::Matrix<T, 3, 3>& d_rot) const {
    if (!valid) return Eigen::Matrix<T, 4, 1>::Zero();
    const T w = q(0), x = q(1), y = q(2), z = q(3);
    const auto& G = d_rot;
    const Eigen::Matrix<T, 4, 1> d_q(
        T(2) * (-z * G(0, 1) + y * G(0, 2) + z * G(1, 0) - x * G(1, 2) -
                y * G(2, 0) + x * G(2, 1)),
        T(2) * (y * G(0, 1) + z * G(0, 2) + y * G(1, 0) - T(2) * x * G(1, 1) -
                w * G(1, 2) + z * G(2, 0) + w * G(2, 1) - T(2) * x * G(2, 2)),
        T(2) * (-T(2) * y * G(0, 0) + x * G(0, 1) + w * G(0, 2) + x * G(1, 0) +
                z * G(1, 2) - w * G(2, 0) + z * G(2, 1) - T(2) * y * G(2, 2)),
        T(2) * (-T(2) * z * G(0, 0) - w * G(0, 1) + x * G(0, 2) + w * G(1, 0) -
                T(2) * z * G(1, 1) + y * G(1, 2) + x * G(2, 0) + y * G(2, 1)));
    // Through the normalisation q / |q|.
    return (d_q - q * q.dot(d_q)) / norm;
  }

  Eigen::Matrix<T, 4, 1> raw;
  T norm;
  bool valid;
  Eigen::Matrix<T, 4, 1> q;  // unit
};

}  // namespace pano4d
