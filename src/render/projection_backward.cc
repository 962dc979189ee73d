// Backward pass of the projection: 2D gradients (pixel mean, conic,
// opacity, colour, depth) to the model's parameters (means, log-scales,
// quaternions, opacity logits, SH coefficients). Each step mirrors one of
// RasterizerT::Project.
#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Geometry>

#include "src/core/error.h"
#include "src/render/quaternion.h"
#include "src/render/rasterizer.h"
#include "src/render/sh.h"

namespace pano4d {

template <typename T>
void GaussianGradientsT<T>::Assign(const GaussianModelT<T>& model) {
  means.assign(model.means.size(), T(0));
  log_scales.assign(model.log_scales.size(), T(0));
  quats.assign(model.quats.size(), T(0));
  opacities.assign(model.opacities.size(), T(0));
  sh.assign(model.sh.size(), T(0));
  means2d.assign(2 * model.size(), T(0));
}

template <typename T>
void RasterizerT<T>::ProjectBackward(const GaussianModelT<T>& model,
                                     const RasterCameraT<T>& camera,
                                     const ProjectedGradientsT<T>& g2d,
                                     GaussianGradientsT<T>* grad) const {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  using Mat3 = Eigen::Matrix<T, 3, 3>;
  using Mat2 = Eigen::Matrix<T, 2, 2>;
  using Mat23 = Eigen::Matrix<T, 2, 3>;
  const ProjectedGaussiansT<T>& p = projected_;
  // The forward's state is indexed by Gaussian: another model (a larger one
  // would be read past the end) or other 2D gradients are refused.
  if (model.size() != p.radius.size() || g2d.x.size() != p.radius.size()) {
    throw Error("rasterizer", "projection backward",
                std::to_string(model.size()) + " Gaussians, 2D gradients of " +
                    std::to_string(g2d.x.size()),
                "the last forward projected " +
                    std::to_string(p.radius.size()) +
                    ": pass the model of that forward and its blend "
                    "backward's gradients");
  }
  grad->Assign(model);
  const int k_count = model.sh_coefficients();
  const T lim_x = T(kFovClamp) * T(0.5) * camera.width / camera.fx;
  const T lim_y = T(kFovClamp) * T(0.5) * camera.height / camera.fy;
  const Vec3 center = camera.Center();

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(model.size());
       ++i) {
    if (p.radius[i] == 0) continue;
    // Recompute the forward's intermediates.
    const Vec3 mean(model.means[3 * i], model.means[3 * i + 1],
                    model.means[3 * i + 2]);
    const Vec3 t = camera.rotation * mean + camera.translation;
    const UnitQuaternion<T> quat(&model.quats[4 * i]);
    const Mat3 rot = quat.Rotation();
    const Vec3 scale(std::exp(model.log_scales[3 * i]),
                     std::exp(model.log_scales[3 * i + 1]),
                     std::exp(model.log_scales[3 * i + 2]));
    const Mat3 m = rot * scale.asDiagonal();
    const Mat3 sigma = m * m.transpose();
    const T inv_z = T(1) / t.z();
    const T ratio_x = t.x() * inv_z, ratio_y = t.y() * inv_z;
    const bool clamp_x = ratio_x < -lim_x || ratio_x > lim_x;
    const bool clamp_y = ratio_y < -lim_y || ratio_y > lim_y;
    const T tx = std::clamp(ratio_x, -lim_x, lim_x) * t.z();
    const T ty = std::clamp(ratio_y, -lim_y, lim_y) * t.z();
    Mat23 j;
    j << camera.fx * inv_z, 0, -camera.fx * tx * inv_z * inv_z, 0,
        camera.fy * inv_z, -camera.fy * ty * inv_z * inv_z;
    const Mat23 a = j * camera.rotation;
    Mat2 conic;
    conic << p.conic_a[i], p.conic_b[i], p.conic_b[i], p.conic_c[i];

    // Opacity: sigmoid.
    const T o = p.opacity[i];
    grad->opacities[i] = g2d.opacity[i] * o * (1 - o);

    // Colour: SH coefficients, and the view direction's share of the mean.
    const Vec3 view = mean - center;
    const Vec3 dir = view.normalized();
    T basis[16], d_basis[48];
    ShBasis(model.sh_degree, dir, basis);
    ShBasisGradient(model.sh_degree, dir, d_basis);
    const T d_color[3] = {p.clamped[3 * i] ? T(0) : g2d.r[i],
                          p.clamped[3 * i + 1] ? T(0) : g2d.g[i],
                          p.clamped[3 * i + 2] ? T(0) : g2d.b[i]};
    Vec3 d_dir = Vec3::Zero();
    const T* coeffs =
        model.sh.data() + static_cast<std::size_t>(i) * k_count * 3;
    T* d_coeffs = grad->sh.data() + static_cast<std::size_t>(i) * k_count * 3;
    for (int k = 0; k < k_count; ++k) {
      for (int c = 0; c < 3; ++c) {
        d_coeffs[3 * k + c] = basis[k] * d_color[c];
        d_dir += Vec3(d_basis[3 * k], d_basis[3 * k + 1], d_basis[3 * k + 2]) *
                 coeffs[3 * k + c] * d_color[c];
      }
    }
    const Vec3 d_mean_view =
        (Mat3::Identity() - dir * dir.transpose()) * d_dir / view.norm();

    // Pixel position and depth.
    Vec3 d_t = Vec3::Zero();
    d_t.x() += g2d.x[i] * camera.fx * inv_z;
    d_t.y() += g2d.y[i] * camera.fy * inv_z;
    d_t.z() += -g2d.x[i] * camera.fx * t.x() * inv_z * inv_z -
               g2d.y[i] * camera.fy * t.y() * inv_z * inv_z;
    d_t.z() += g2d.depth[i];
    grad->means2d[2 * i] = g2d.x[i];
    grad->means2d[2 * i + 1] = g2d.y[i];

    // Conic = cov^-1: dL/dcov = -C G C, with G symmetric (b is shared).
    Mat2 g;
    g << g2d.conic_a[i], T(0.5) * g2d.conic_b[i], T(0.5) * g2d.conic_b[i],
        g2d.conic_c[i];
    const Mat2 d_cov = -conic * g * conic;

    // cov = A Sigma A^T + low-pass, A = J W.
    const Mat3 d_sigma = a.transpose() * d_cov * a;
    const Mat23 d_a = T(2) * d_cov * a * sigma;
    const Mat23 d_j = d_a * camera.rotation.transpose();
    // J's dependence on t (tx, ty are clamped copies of t.x, t.y).
    const T d_tx = d_j(0, 2) * (-camera.fx * inv_z * inv_z);
    const T d_ty = d_j(1, 2) * (-camera.fy * inv_z * inv_z);
    d_t.z() += d_j(0, 0) * (-camera.fx * inv_z * inv_z) +
               d_j(0, 2) * (T(2) * camera.fx * tx * inv_z * inv_z * inv_z) +
               d_j(1, 1) * (-camera.fy * inv_z * inv_z) +
               d_j(1, 2) * (T(2) * camera.fy * ty * inv_z * inv_z * inv_z);
    if (clamp_x) {
      d_t.z() += d_tx * (ratio_x < 0 ? -lim_x : lim_x);
    } else {
      d_t.x() += d_tx;
    }
    if (clamp_y) {
      d_t.z() += d_ty * (ratio_y < 0 ? -lim_y : lim_y);
    } else {
      d_t.y() += d_ty;
    }
    const Vec3 d_mean = camera.rotation.transpose() * d_t + d_mean_view;
    for (int k = 0; k < 3; ++k) grad->means[3 * i + k] = d_mean(k);

    // Sigma = M M^T, M = R S.
    const Mat3 d_m = T(2) * d_sigma * m;
    for (int k = 0; k < 3; ++k)
      grad->log_scales[3 * i + k] = scale(k) * rot.col(k).dot(d_m.col(k));
    const Mat3 d_r = d_m * scale.asDiagonal();
    // The identity stands in for a degenerate quaternion: no gradient.
    const Eigen::Matrix<T, 4, 1> d_q_raw = quat.Backward(d_r);
    for (int k = 0; k < 4; ++k) grad->quats[4 * i + k] = d_q_raw(k);
  }
}

template struct GaussianGradientsT<float>;
template struct GaussianGradientsT<double>;
template void RasterizerT<float>::ProjectBackward(
    const GaussianModelT<float>&, const RasterCameraT<float>&,
    const ProjectedGradientsT<float>&, GaussianGradientsT<float>*) const;
template void RasterizerT<double>::ProjectBackward(
    const GaussianModelT<double>&, const RasterCameraT<double>&,
    const ProjectedGradientsT<double>&, GaussianGradientsT<double>*) const;

}  // namespace pano4d
