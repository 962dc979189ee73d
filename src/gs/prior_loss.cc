#include "src/gs/prior_loss.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "src/core/error.h"
#include "src/core/median.h"
#include "src/render/rasterizer.h"

namespace pano4d {
namespace {

// A camera-frame point's pixel and the Jacobian of the pixel with respect
// to the world point; false behind the near plane.
template <typename T>
bool ProjectWithJacobian(const RasterCameraT<T>& camera, const T* mean,
                         Eigen::Matrix<T, 2, 1>* pixel,
                         Eigen::Matrix<T, 2, 3>* jacobian, T* z) {
  const Eigen::Matrix<T, 3, 1> world(mean[0], mean[1], mean[2]);
  const Eigen::Matrix<T, 3, 1> c = camera.rotation * world + camera.translation;
  if (!(c.z() > T(kNearPlane))) return false;
  const T inv = T(1) / c.z();
  *pixel << camera.fx * c.x() * inv + camera.cx,
      camera.fy * c.y() * inv + camera.cy;
  Eigen::Matrix<T, 2, 3> d_camera;
  d_camera << camera.fx * inv, T(0), -camera.fx * c.x() * inv * inv, T(0),
      camera.fy * inv, -camera.fy * c.y() * inv * inv;
  *jacobian = d_camera * camera.rotation;
  *z = c.z();
  return true;
}

void CheckSizes(const char* term, std::size_t got, std::size_t expected,
                const char* what) {
  if (got == expected) return;
  throw Error(term, what, std::to_string(got),
              "expected " + std::to_string(expected) + " values");
}

}  // namespace

template <typename T>
FlowTerm FlowLoss(const GaussianModelT<T>& at_a, std::size_t first,
                  const std::vector<T>& means_b,
                  const RasterCameraT<T>& camera_a,
                  const RasterCameraT<T>& camera_b,
                  const std::vector<float>& flow,
                  const std::vector<std::uint8_t>& valid,
                  const std::vector<float>& rendered_depth, double weight,
                  double tolerance, double huber_pixels,
                  std::vector<T>* d_means_a, std::vector<T>* d_means_b) {
  using Vec2 = Eigen::Matrix<T, 2, 1>;
  const int w = camera_a.width, h = camera_a.height;
  const std::size_t pixels = static_cast<std::size_t>(w) * h;
  const std::size_t n = at_a.size();
  const std::size_t nd = n > first ? n - first : 0;
  CheckSizes("flow loss", flow.size(), pixels * 2, "flow");
  CheckSizes("flow loss", valid.size(), pixels, "valid");
  CheckSizes("flow loss", rendered_depth.size(), pixels, "rendered depth");
  CheckSizes("flow loss", means_b.size(), nd * 3, "means_b");
  CheckSizes("flow loss", d_means_a->size(), n * 3, "d_means_a");
  CheckSizes("flow loss", d_means_b->size(), nd * 3, "d_means_b");
  FlowTerm term;
  if (weight == 0 || nd == 0) return term;

  // Per dynamic row: the residual, and the Jacobians that carry it back
  // (a row with used[j] = 0 is not on a's visible surface, or has no flow).
  std::vector<Vec2> residual(nd, Vec2::Zero());
  std::vector<Eigen::Matrix<T, 2, 3>> jacobian_a(nd), jacobian_b(nd);
  std::vector<std::uint8_t> used(nd, 0);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t j = 0; j < static_cast<std::ptrdiff_t>(nd); ++j) {
    Vec2 pa, pb;
    T za, zb;
    if (!ProjectWithJacobian(camera_a, &at_a.means[3 * (first + j)], &pa,
                             &jacobian_a[j], &za))
      continue;
    if (!(pa.x() >= 0 && pa.y() >= 0 && pa.x() < w && pa.y() < h)) continue;
    const std::size_t p = static_cast<std::size_t>(pa.y()) * w +
                          static_cast<std::size_t>(pa.x());
    const float d = rendered_depth[p];
    if (!valid[p] || !(d > 0) || std::abs(za - T(d)) > T(tolerance) * T(d))
      continue;
    if (!ProjectWithJacobian(camera_b, &means_b[3 * j], &pb, &jacobian_b[j],
                             &zb))
      continue;
    residual[j] = pb - pa - Vec2(T(flow[2 * p]), T(flow[2 * p + 1]));
    used[j] = 1;
  }
  double sum = 0, error = 0;
  for (std::size_t j = 0; j < nd; ++j) {
    if (!used[j]) continue;
    ++term.gaussians;
    const double r = static_cast<double>(residual[j].norm());
    error += r;
    sum += r <= huber_pixels ? r * r / (2 * huber_pixels)
                             : r - huber_pixels / 2;
  }
  if (term.gaussians == 0) return term;
  const double norm = weight / (static_cast<double>(term.gaussians) * w);
  term.loss = norm * sum;
  term.mean_error = error / static_cast<double>(term.gaussians);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t j = 0; j < static_cast<std::ptrdiff_t>(nd); ++j) {
    if (!used[j]) continue;
    const T r = residual[j].norm();
    const T huber = static_cast<T>(huber_pixels);
    // dHuber/dr: r / delta inside, the unit direction outside.
    const Vec2 g = (r <= huber ? residual[j] / huber
                               : residual[j] / std::max(r, T(1e-12))) *
                   static_cast<T>(norm);
    const Eigen::Matrix<T, 3, 1> ga = -(jacobian_a[j].transpose() * g);
    const Eigen::Matrix<T, 3, 1> gb = jacobian_b[j].transpose() * g;
    for (int k = 0; k < 3; ++k) {
      (*d_means_a)[3 * (first + j) + k] += ga(k);
      (*d_means_b)[3 * j + k] += gb(k);
    }
  }
  return term;
}

DisparityTerm DisparityLoss(const std::vector<float>& disparity,
                            const std::vector<float>& rendered_depth,
                            double weight, std::vector<float>* d_rendered_depth,
                            const std::vector<std::uint8_t>* mask) {
  CheckSizes("disparity loss", rendered_depth.size(), disparity.size(),
             "rendered depth");
  if (mask) CheckSizes("disparity loss", mask->size(), disparity.size(), "mask");
  const auto in = [&](std::size_t p) {
    return std::isfinite(disparity[p]) && rendered_depth[p] > 0 &&
           (!mask || (*mask)[p] != 0);
  };
  CheckSizes("disparity loss", d_rendered_depth->size(), disparity.size(),
             "gradient");
  DisparityTerm term;
  if (weight == 0) return term;
  // The least-squares affine s D + b ~ 1 / z over the pixels that have
  // both (normal equations in double).
  double n = 0, sd = 0, sdd = 0, si = 0, sdi = 0;
  std::vector<double> inverse;
  inverse.reserve(disparity.size() / 4);
  for (std::size_t p = 0; p < disparity.size(); ++p) {
    if (!in(p)) continue;
    const double d = disparity[p], z = rendered_depth[p];
    const double i = 1.0 / z;
    n += 1;
    sd += d;
    sdd += d * d;
    si += i;
    sdi += d * i;
    inverse.push_back(i);
  }
  const double det = n * sdd - sd * sd;
  // Too few pixels, or a constant prior: no affine to fit.
  if (n < 2 || !(det > 1e-12 * n * n * std::max(1.0, sdd / n))) return term;
  term.scale = (n * sdi - sd * si) / det;
  term.shift = (si - term.scale * sd) / n;
  const double median = UpperMedian(std::move(inverse));
  if (!(median > 0)) return term;
  term.pixels = static_cast<std::int64_t>(n);
  const double norm = weight / (n * median);
  double sum = 0;
  for (std::size_t p = 0; p < disparity.size(); ++p) {
    if (!in(p)) continue;
    const double d = disparity[p], z = rendered_depth[p];
    const double e = term.scale * d + term.shift - 1.0 / z;
    sum += std::abs(e);
    // d|e|/dz = sign(e) / z^2 (e falls as 1 / z rises).
    const double sign = e > 0 ? 1.0 : (e < 0 ? -1.0 : 0.0);
    (*d_rendered_depth)[p] += static_cast<float>(norm * sign / (z * z));
  }
  term.loss = norm * sum;
  return term;
}

template FlowTerm FlowLoss(const GaussianModelT<float>&, std::size_t,
                           const std::vector<float>&,
                           const RasterCameraT<float>&,
                           const RasterCameraT<float>&,
                           const std::vector<float>&,
                           const std::vector<std::uint8_t>&,
                           const std::vector<float>&, double, double, double,
                           std::vector<float>*, std::vector<float>*);
template FlowTerm FlowLoss(const GaussianModelT<double>&, std::size_t,
                           const std::vector<double>&,
                           const RasterCameraT<double>&,
                           const RasterCameraT<double>&,
                           const std::vector<float>&,
                           const std::vector<std::uint8_t>&,
                           const std::vector<float>&, double, double, double,
                           std::vector<double>*, std::vector<double>*);

}  // namespace pano4d
