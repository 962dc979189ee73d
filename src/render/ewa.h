#pragma once
// The projection's pieces of arithmetic, each written once with its
// vector-Jacobian product (VJP) beside it: the projection's forward and
// backward (projection.cc) call the same functions, so the backward never
// re-derives what the forward computed. A VJP adds into the gradients it
// returns through pointers (`d_t` collects several terms) or writes them
// (the others), as its comment says.
#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "src/render/gaussians.h"
#include "src/render/quaternion.h"
#include "src/render/rasterizer.h"

namespace pano4d {

// Every piece is inlined into the projection's per-Gaussian loops: GCC
// kept some out of line, which cost those loops a few percent.
#define PANO4D_EWA_INLINE [[gnu::always_inline]] inline

// A Gaussian's 3D covariance Sigma = M M^T with M = R S: R from its
// normalised quaternion, S = diag(exp(log_scales)).
template <typename T>
struct Covariance3dT {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  using Mat3 = Eigen::Matrix<T, 3, 3>;
  PANO4D_EWA_INLINE Covariance3dT(const UnitQuaternion<T>& quat,
                                  const T* log_scales)
      : rot(quat.Rotation()),
        scale(std::exp(log_scales[0]), std::exp(log_scales[1]),
              std::exp(log_scales[2])),
        m(rot * scale.asDiagonal()),
        sigma(m * m.transpose()) {}

  // d_sigma (symmetric) -> d_log_scales (3, written) and d_rot (written),
  // which UnitQuaternion::Backward carries to the raw quaternion.
  PANO4D_EWA_INLINE void Vjp(const Mat3& d_sigma, T* d_log_scales,
                             Mat3* d_rot) const {
    const Mat3 d_m = T(2) * d_sigma * m;
    for (int k = 0; k < 3; ++k)
      d_log_scales[k] = scale(k) * rot.col(k).dot(d_m.col(k));
    *d_rot = d_m * scale.asDiagonal();
  }

  Mat3 rot;
  Vec3 scale;
  Mat3 m;
  Mat3 sigma;
};

// The camera's bounds on x / z and y / z where the EWA Jacobian is
// evaluated: kFovClamp x the half field of view (3DGS).
template <typename T>
struct FovLimits {
  explicit FovLimits(const RasterCameraT<T>& camera)
      : x(T(kFovClamp) * T(0.5) * camera.width / camera.fx),
        y(T(kFovClamp) * T(0.5) * camera.height / camera.fy) {}
  T x, y;
};

// The EWA splatting Jacobian J = d pixel / d t of the perspective
// projection at the camera-space point t (t.z > 0), with t's direction
// clamped to FovLimits: a point far outside the image would otherwise get
// a huge footprint.
template <typename T>
struct PerspectiveJacobianT {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  using Mat23 = Eigen::Matrix<T, 2, 3>;
  PANO4D_EWA_INLINE PerspectiveJacobianT(const Vec3& t,
                                         const RasterCameraT<T>& camera,
                                         const FovLimits<T>& lim)
      : inv_z(T(1) / t.z()),
        ratio_x(t.x() * inv_z),
        ratio_y(t.y() * inv_z),
        clamp_x(ratio_x < -lim.x || ratio_x > lim.x),
        clamp_y(ratio_y < -lim.y || ratio_y > lim.y),
        tx(std::clamp(ratio_x, -lim.x, lim.x) * t.z()),
        ty(std::clamp(ratio_y, -lim.y, lim.y) * t.z()) {
    j << camera.fx * inv_z, 0, -camera.fx * tx * inv_z * inv_z,  //
        0, camera.fy * inv_z, -camera.fy * ty * inv_z * inv_z;
  }

  // d_j -> d_t (added). The clamped coordinates are t.z times a constant
  // ratio: their share goes to t.z.
  PANO4D_EWA_INLINE void Vjp(const RasterCameraT<T>& camera,
                             const FovLimits<T>& lim, const Mat23& d_j,
                             Vec3* d_t) const {
    const T d_tx = d_j(0, 2) * (-camera.fx * inv_z * inv_z);
    const T d_ty = d_j(1, 2) * (-camera.fy * inv_z * inv_z);
    d_t->z() += d_j(0, 0) * (-camera.fx * inv_z * inv_z) +
                d_j(0, 2) * (T(2) * camera.fx * tx * inv_z * inv_z * inv_z) +
                d_j(1, 1) * (-camera.fy * inv_z * inv_z) +
                d_j(1, 2) * (T(2) * camera.fy * ty * inv_z * inv_z * inv_z);
    if (clamp_x) {
      d_t->z() += d_tx * (ratio_x < 0 ? -lim.x : lim.x);
    } else {
      d_t->x() += d_tx;
    }
    if (clamp_y) {
      d_t->z() += d_ty * (ratio_y < 0 ? -lim.y : lim.y);
    } else {
      d_t->y() += d_ty;
    }
  }

  T inv_z, ratio_x, ratio_y;
  bool clamp_x, clamp_y;
  T tx, ty;  // t.x, t.y with the direction clamped
  Mat23 j;
};

// The pixel of the camera-space point t: (fx t.x / t.z + cx, fy t.y / t.z
// + cy), given inv_z = 1 / t.z.
template <typename T>
PANO4D_EWA_INLINE Eigen::Matrix<T, 2, 1> ProjectPoint(
    const Eigen::Matrix<T, 3, 1>& t, const RasterCameraT<T>& camera, T inv_z) {
  return {camera.fx * t.x() * inv_z + camera.cx,
          camera.fy * t.y() * inv_z + camera.cy};
}
// d pixel (d_px, d_py) -> d_t (added).
template <typename T>
PANO4D_EWA_INLINE void ProjectPointVjp(const Eigen::Matrix<T, 3, 1>& t,
                                       const RasterCameraT<T>& camera, T inv_z,
                                       T d_px, T d_py,
                                       Eigen::Matrix<T, 3, 1>* d_t) {
  d_t->x() += d_px * camera.fx * inv_z;
  d_t->y() += d_py * camera.fy * inv_z;
  d_t->z() += -d_px * camera.fx * t.x() * inv_z * inv_z -
              d_py * camera.fy * t.y() * inv_z * inv_z;
}

// The 2D covariance A Sigma A^T + kLowPass I of a Gaussian, A = J W (the
// EWA Jacobian times the camera rotation).
template <typename T>
PANO4D_EWA_INLINE Eigen::Matrix<T, 2, 2> ProjectCovariance(
    const Eigen::Matrix<T, 2, 3>& a, const Eigen::Matrix<T, 3, 3>& sigma) {
  return a * sigma * a.transpose() +
         T(kLowPass) * Eigen::Matrix<T, 2, 2>::Identity();
}
// d_cov (symmetric) -> d_sigma and d_a (written).
template <typename T>
PANO4D_EWA_INLINE void ProjectCovarianceVjp(const Eigen::Matrix<T, 2, 3>& a,
                                            const Eigen::Matrix<T, 3, 3>& sigma,
                                            const Eigen::Matrix<T, 2, 2>& d_cov,
                                            Eigen::Matrix<T, 3, 3>* d_sigma,
                                            Eigen::Matrix<T, 2, 3>* d_a) {
  *d_sigma = a.transpose() * d_cov * a;
  *d_a = T(2) * d_cov * a * sigma;
}

// The conic [a b; b c] = cov^-1 of a 2D covariance with determinant det > 0.
template <typename T>
PANO4D_EWA_INLINE Eigen::Matrix<T, 3, 1> InverseCovariance(
    const Eigen::Matrix<T, 2, 2>& cov, T det) {
  return {cov(1, 1) / det, -cov(0, 1) / det, cov(0, 0) / det};
}
// Gradients with respect to the conic's a, b, c -> d_cov = -C G C, with G
// symmetric (b stands for both off-diagonal entries).
template <typename T>
PANO4D_EWA_INLINE Eigen::Matrix<T, 2, 2> InverseCovarianceVjp(
    const Eigen::Matrix<T, 2, 2>& conic, T d_a, T d_b, T d_c) {
  Eigen::Matrix<T, 2, 2> g;
  g << d_a, T(0.5) * d_b, T(0.5) * d_b, d_c;
  return -conic * g * conic;
}

// opacity = sigmoid(logit); d opacity -> d logit.
template <typename T>
PANO4D_EWA_INLINE T Sigmoid(T logit) {
  return T(1.0) / (T(1.0) + std::exp(-logit));
}
template <typename T>
PANO4D_EWA_INLINE T SigmoidVjp(T opacity, T d_opacity) {
  return d_opacity * opacity * (1 - opacity);
}

#undef PANO4D_EWA_INLINE

}  // namespace pano4d
