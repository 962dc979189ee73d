// Projection forward and backward (projection.h). Both evaluate the same
// pieces (ewa.h, sh.h, quaternion.h); the backward calls each one's VJP in
// reverse order.
#include "src/render/projection.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include <Eigen/Geometry>

#include "src/core/check.h"
#include "src/core/error.h"
#include "src/render/ewa.h"
#include "src/render/quaternion.h"
#include "src/render/sh.h"

namespace pano4d {

template <typename T>
void ProjectedGaussiansT<T>::Resize(std::size_t n) {
  for (auto* v : {&x, &y, &depth, &conic_a, &conic_b, &conic_c, &opacity, &r,
                  &g, &b, &extent_x, &extent_y})
    v->resize(n);
  for (auto* v : {&radius, &tile_x0, &tile_y0, &tile_x1, &tile_y1})
    v->resize(n);
  clamped.resize(3 * n);
}

template <typename T>
void ProjectedGradientsT<T>::Assign(std::size_t n) {
  for (auto* v :
       {&x, &y, &conic_a, &conic_b, &conic_c, &opacity, &r, &g, &b, &depth})
    v->assign(n, T(0));
}

template <typename T>
void ProjectedGradientsT<T>::Resize(std::size_t n) {
  for (auto* v :
       {&x, &y, &conic_a, &conic_b, &conic_c, &opacity, &r, &g, &b, &depth})
    v->resize(n);
}

template <typename T>
void GaussianGradientsT<T>::Assign(const GaussianModelT<T>& model) {
  means.assign(model.means.size(), T(0));
  log_scales.assign(model.log_scales.size(), T(0));
  quats.assign(model.quats.size(), T(0));
  opacities.assign(model.opacities.size(), T(0));
  sh.assign(model.sh.size(), T(0));
  means2d.assign(2 * model.size(), T(0));
}

namespace {

// Where a projected Gaussian's alpha >= kMinAlpha box lies: its half-sizes,
// its 3-sigma radius, and the tiles it touches, [x0, x1) x [y0, y1).
template <typename T>
struct Footprint {
  T extent_x, extent_y, radius;
  int x0, x1, y0, y1;
};

// alpha >= kMinAlpha <=> d^T conic d <= 2 ln(opacity / kMinAlpha): the
// bounding box of that ellipse has half-sizes sqrt(k cov_xx), sqrt(k
// cov_yy) (the footprint the opacity allows: a faint Gaussian's is smaller
// than 3 sigma, an opaque one's up to 3.3 sigma), bounded along each axis
// rather than by the square of the largest axis. nullopt when a value is
// not finite or no tile is touched.
template <typename T>
std::optional<Footprint<T>> FootprintOf(const Eigen::Matrix<T, 2, 2>& cov,
                                        T det, T opacity, T px, T py,
                                        int tiles_x, int tiles_y) {
  Footprint<T> f;
  const T k = T(2.0) * std::log(opacity / T(kMinAlpha));
  // Clamped as the radius is, so that tile arithmetic stays in range.
  f.extent_x =
      std::min(T(kMaxRadius), std::sqrt(k * cov(0, 0)) + T(kAlphaBoxMargin));
  f.extent_y =
      std::min(T(kMaxRadius), std::sqrt(k * cov(1, 1)) + T(kAlphaBoxMargin));
  const T mid = T(0.5) * (cov(0, 0) + cov(1, 1));
  const T lambda = mid + std::sqrt(std::max(T(0.1), mid * mid - det));
  f.radius = std::min(T(kMaxRadius), std::ceil(T(3.0) * std::sqrt(lambda)));
  if (!std::isfinite(f.radius) || !std::isfinite(f.extent_x) ||
      !std::isfinite(f.extent_y) || !std::isfinite(px) || !std::isfinite(py))
    return std::nullopt;
  const auto tile = [](T v, int tiles) {
    return static_cast<int>(
        std::clamp(v / kTileSize, T(0.0), static_cast<T>(tiles)));
  };
  f.x0 = tile(px - f.extent_x, tiles_x);
  f.x1 = tile(px + f.extent_x + kTileSize - 1, tiles_x);
  f.y0 = tile(py - f.extent_y, tiles_y);
  f.y1 = tile(py + f.extent_y + kTileSize - 1, tiles_y);
  if (f.x1 <= f.x0 || f.y1 <= f.y0) return std::nullopt;
  return f;
}

// Gaussian i projected into `p`; radius 0 where it is behind the near
// plane, degenerate, below kMinAlpha everywhere or outside the image.
template <typename T>
void ProjectGaussian(const GaussianModelT<T>& model,
                     const RasterCameraT<T>& camera, const FovLimits<T>& lim,
                     const Eigen::Matrix<T, 3, 1>& center, int tiles_x,
                     int tiles_y, std::ptrdiff_t i,
                     ProjectedGaussiansT<T>* pp) {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  ProjectedGaussiansT<T>& p = *pp;
  p.radius[i] = 0;
  const Vec3 mean(model.means[3 * i], model.means[3 * i + 1],
                  model.means[3 * i + 2]);
  const Vec3 t = camera.rotation * mean + camera.translation;
  if (!(t.z() > T(kNearPlane)) || !t.allFinite()) return;
  const Covariance3dT<T> cov3d(UnitQuaternion<T>(&model.quats[4 * i]),
                               &model.log_scales[3 * i]);
  const PerspectiveJacobianT<T> jac(t, camera, lim);
  const Eigen::Matrix<T, 2, 2> cov =
      ProjectCovariance<T>(jac.j * camera.rotation, cov3d.sigma);
  const T det = cov(0, 0) * cov(1, 1) - cov(0, 1) * cov(0, 1);
  if (!(det > 0) || !std::isfinite(det)) return;
  // A Gaussian below kMinAlpha everywhere never contributes.
  const T opacity = Sigmoid(model.opacities[i]);
  if (!(opacity >= T(kMinAlpha))) return;
  const Eigen::Matrix<T, 2, 1> pixel = ProjectPoint(t, camera, jac.inv_z);
  const std::optional<Footprint<T>> f =
      FootprintOf(cov, det, opacity, pixel.x(), pixel.y(), tiles_x, tiles_y);
  if (!f) return;
  p.x[i] = pixel.x();
  p.y[i] = pixel.y();
  p.depth[i] = t.z();
  const Eigen::Matrix<T, 3, 1> conic = InverseCovariance(cov, det);
  p.conic_a[i] = conic(0);
  p.conic_b[i] = conic(1);
  p.conic_c[i] = conic(2);
  p.opacity[i] = opacity;
  p.extent_x[i] = f->extent_x;
  p.extent_y[i] = f->extent_y;
  bool clamped[3];
  const int k_count = model.sh_coefficients();
  const Vec3 color =
      ShColor(model.sh_degree,
              model.sh.data() + static_cast<std::size_t>(i) * k_count * 3,
              (mean - center).normalized(), clamped);
  p.r[i] = color.x();
  p.g[i] = color.y();
  p.b[i] = color.z();
  for (int c = 0; c < 3; ++c) p.clamped[3 * i + c] = clamped[c];
  p.tile_x0[i] = f->x0;
  p.tile_x1[i] = f->x1;
  p.tile_y0[i] = f->y0;
  p.tile_y1[i] = f->y1;
  p.radius[i] = static_cast<int>(f->radius);
}

}  // namespace

template <typename T>
void ProjectionForward(const GaussianModelT<T>& model,
                       const RasterCameraT<T>& camera,
                       ProjectedGaussiansT<T>* projected) {
  const std::size_t n = model.size();
  projected->Resize(n);
  const int tiles_x = (camera.width + kTileSize - 1) / kTileSize;
  const int tiles_y = (camera.height + kTileSize - 1) / kTileSize;
  const FovLimits<T> lim(camera);
  const Eigen::Matrix<T, 3, 1> center = camera.Center();
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i)
    ProjectGaussian(model, camera, lim, center, tiles_x, tiles_y, i, projected);
}

template <typename T>
void ProjectionBackward(const GaussianModelT<T>& model,
                        const RasterCameraT<T>& camera,
                        const ProjectedGaussiansT<T>& p,
                        const ProjectedGradientsT<T>& g2d,
                        GaussianGradientsT<T>* grad) {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  using Mat3 = Eigen::Matrix<T, 3, 3>;
  using Mat2 = Eigen::Matrix<T, 2, 2>;
  using Mat23 = Eigen::Matrix<T, 2, 3>;
  // The forward's results are indexed by Gaussian: another model (a larger
  // one would be read past the end) or other 2D gradients are refused.
  PANO4D_CHECK(
      model.size() == p.radius.size() && g2d.x.size() == p.radius.size(),
      "the projection's backward got " + std::to_string(model.size()) +
          " Gaussians and 2D gradients of " + std::to_string(g2d.x.size()) +
          " for a forward that projected " + std::to_string(p.radius.size()));
  grad->Assign(model);
  const int k_count = model.sh_coefficients();
  const FovLimits<T> lim(camera);
  const Vec3 center = camera.Center();

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(model.size());
       ++i) {
    if (p.radius[i] == 0) continue;
    // The forward's pieces, evaluated again (cheaper than storing them).
    const Vec3 mean(model.means[3 * i], model.means[3 * i + 1],
                    model.means[3 * i + 2]);
    const Vec3 t = camera.rotation * mean + camera.translation;
    const UnitQuaternion<T> quat(&model.quats[4 * i]);
    const Covariance3dT<T> cov3d(quat, &model.log_scales[3 * i]);
    const PerspectiveJacobianT<T> jac(t, camera, lim);
    const Mat23 a = jac.j * camera.rotation;
    Mat2 conic;
    conic << p.conic_a[i], p.conic_b[i], p.conic_b[i], p.conic_c[i];

    grad->opacities[i] = SigmoidVjp(p.opacity[i], g2d.opacity[i]);

    // Colour: SH coefficients, and the view direction's share of the mean.
    const T d_color[3] = {p.clamped[3 * i] ? T(0) : g2d.r[i],
                          p.clamped[3 * i + 1] ? T(0) : g2d.g[i],
                          p.clamped[3 * i + 2] ? T(0) : g2d.b[i]};
    const Vec3 d_mean_view =
        ShColorVjp(model.sh_degree,
                   model.sh.data() + static_cast<std::size_t>(i) * k_count * 3,
                   Vec3(mean - center), d_color,
                   grad->sh.data() + static_cast<std::size_t>(i) * k_count * 3);

    // Pixel position and depth.
    Vec3 d_t = Vec3::Zero();
    ProjectPointVjp(t, camera, jac.inv_z, g2d.x[i], g2d.y[i], &d_t);
    d_t.z() += g2d.depth[i];
    grad->means2d[2 * i] = g2d.x[i];
    grad->means2d[2 * i + 1] = g2d.y[i];

    // Conic -> 2D covariance -> 3D covariance and the EWA Jacobian.
    const Mat2 d_cov = InverseCovarianceVjp(conic, g2d.conic_a[i],
                                            g2d.conic_b[i], g2d.conic_c[i]);
    Mat3 d_sigma;
    Mat23 d_a;
    ProjectCovarianceVjp(a, cov3d.sigma, d_cov, &d_sigma, &d_a);
    jac.Vjp(camera, lim, Mat23(d_a * camera.rotation.transpose()), &d_t);
    const Vec3 d_mean = camera.rotation.transpose() * d_t + d_mean_view;
    for (int k = 0; k < 3; ++k) grad->means[3 * i + k] = d_mean(k);

    Mat3 d_rot;
    cov3d.Vjp(d_sigma, &grad->log_scales[3 * i], &d_rot);
    // The identity stands in for a degenerate quaternion: no gradient.
    const Eigen::Matrix<T, 4, 1> d_q_raw = quat.Backward(d_rot);
    for (int k = 0; k < 4; ++k) grad->quats[4 * i + k] = d_q_raw(k);
  }
}

template struct ProjectedGaussiansT<float>;
template struct ProjectedGaussiansT<double>;
template struct ProjectedGradientsT<float>;
template struct ProjectedGradientsT<double>;
template struct GaussianGradientsT<float>;
template struct GaussianGradientsT<double>;
template void ProjectionForward(const GaussianModelT<float>&,
                                const RasterCameraT<float>&,
                                ProjectedGaussiansT<float>*);
template void ProjectionForward(const GaussianModelT<double>&,
                                const RasterCameraT<double>&,
                                ProjectedGaussiansT<double>*);
template void ProjectionBackward(const GaussianModelT<float>&,
                                 const RasterCameraT<float>&,
                                 const ProjectedGaussiansT<float>&,
                                 const ProjectedGradientsT<float>&,
                                 GaussianGradientsT<float>*);
template void ProjectionBackward(const GaussianModelT<double>&,
                                 const RasterCameraT<double>&,
                                 const ProjectedGaussiansT<double>&,
                                 const ProjectedGradientsT<double>&,
                                 GaussianGradientsT<double>*);

}  // namespace pano4d
