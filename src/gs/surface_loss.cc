#include "src/gs/surface_loss.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "src/core/error.h"
#include "src/render/quaternion.h"
#include "src/render/rasterizer.h"

namespace pano4d {

namespace {

// The variances along the local axes divided by the largest: f and its
// gradients depend on their ratios only, and exp(2 log s) alone overflows
// for log-scales above about 44 (float) and underflows below -44.
template <typename T>
Eigen::Matrix<T, 3, 1> RelativeVariances(const T* log_scales) {
  const T top = std::max({log_scales[0], log_scales[1], log_scales[2]});
  return Eigen::Matrix<T, 3, 1>(std::exp(T(2) * (log_scales[0] - top)),
                                std::exp(T(2) * (log_scales[1] - top)),
                                std::exp(T(2) * (log_scales[2] - top)));
}

// Where row i's centre lands in `camera`: its camera-frame position and
// pixel. False behind the near plane or outside the image.
template <typename T>
bool CentrePixel(const GaussianModelT<T>& model, std::size_t i,
                 const RasterCameraT<T>& camera, Eigen::Matrix<T, 3, 1>* t,
                 int* px, int* py) {
  const Eigen::Matrix<T, 3, 1> mean(model.means[3 * i], model.means[3 * i + 1],
                                    model.means[3 * i + 2]);
  *t = camera.rotation * mean + camera.translation;
  if (!(t->z() > T(kNearPlane))) return false;
  const T u = camera.fx * t->x() / t->z() + camera.cx;
  const T v = camera.fy * t->y() / t->z() + camera.cy;
  if (!(u >= 0 && v >= 0 && u < camera.width && v < camera.height))
    return false;
  *px = static_cast<int>(u);
  *py = static_cast<int>(v);
  return true;
}

}  // namespace

template <typename T>
bool DepthNormalAt(const std::vector<float>& depth,
                   const RasterCameraT<T>& camera, int x, int y,
                   Eigen::Matrix<T, 3, 1>* normal) {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  const int w = camera.width, h = camera.height;
  if (x < 1 || y < 1 || x + 1 >= w || y + 1 >= h) return false;
  const auto at = [&](int px, int py) {
    return depth[static_cast<std::size_t>(py) * w + px];
  };
  const float z = at(x, y);
  if (!(z > 0)) return false;
  for (auto [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
    const float zn = at(x + dx, y + dy);
    if (!(zn > 0) || std::abs(zn - z) > kNormalEdgeJump * z) return false;
  }
  const auto point = [&](int px, int py) {
    const T d = at(px, py);
    return camera.CameraPoint(px + T(0.5), py + T(0.5), d);
  };
  const Vec3 n = (point(x + 1, y) - point(x - 1, y))
                     .cross(point(x, y + 1) - point(x, y - 1));
  const T length = n.norm();
  if (!(length > T(0))) return false;
  *normal = n / length;
  return true;
}

template <typename T>
NormalFlatness NormalFlatnessLoss(const GaussianModelT<T>& model,
                                  const RasterCameraT<T>& camera,
                                  const std::vector<float>& depth,
                                  double weight, double tolerance,
                                  std::vector<T>* d_log_scales,
                                  std::vector<T>* d_quats) {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  using Mat3 = Eigen::Matrix<T, 3, 3>;
  const int w = camera.width, h = camera.height;
  const std::size_t n = model.size();
  if (depth.size() != static_cast<std::size_t>(w) * h) {
    throw Error("normal flatness", "depth", std::to_string(depth.size()),
                "expected " + std::to_string(w) + " x " + std::to_string(h) +
                    " values (the camera's size)");
  }
  if (d_log_scales->size() != n * 3 || d_quats->size() != n * 4) {
    throw Error("normal flatness", "gradients",
                std::to_string(d_log_scales->size()),
                "expected arrays sized like the model's " + std::to_string(n) +
                    " Gaussians");
  }
  NormalFlatness result;
  if (weight == 0 || n == 0) return result;

  // Per Gaussian: f_i (or -1 when left out) and the world normal it was
  // taken against; then the mean's scale.
  std::vector<T> f(n, T(-1));
  std::vector<Vec3> normals(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    Vec3 t;
    int px, py;
    if (!CentrePixel(model, i, camera, &t, &px, &py)) continue;
    const float d = depth[static_cast<std::size_t>(py) * w + px];
    if (!(d > 0) || std::abs(t.z() - T(d)) > T(tolerance) * T(d)) continue;
    Vec3 normal_camera;
    if (!DepthNormalAt(depth, camera, px, py, &normal_camera)) continue;
    const Vec3 normal = camera.rotation.transpose() * normal_camera;
    normals[i] = normal;
    const UnitQuaternion<T> quat(&model.quats[4 * i]);
    const Mat3 rot = quat.Rotation();
    const Vec3 local = rot.transpose() * normal;  // m_k = r_k . n
    const Vec3 var = RelativeVariances(&model.log_scales[3 * i]);
    const T trace = var.sum();
    f[i] = var.dot(local.cwiseProduct(local)) / trace;
  }
  std::int64_t used = 0;
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (f[i] < 0) continue;
    ++used;
    sum += f[i];
  }
  if (used == 0) return result;
  result.gaussians = used;
  result.loss = weight * sum / static_cast<double>(used);
  const T scale = static_cast<T>(weight / static_cast<double>(used));

  // Gradients: f = sum_k s_k^2 m_k^2 / S with S = sum_k s_k^2, m = R^T n:
  //   df/dlog s_k = 2 s_k^2 (m_k^2 - f) / S,  df/dR(:, k) = 2 s_k^2 m_k n / S.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    if (f[i] < 0) continue;
    const Vec3& normal = normals[i];
    const UnitQuaternion<T> quat(&model.quats[4 * i]);
    const Mat3 rot = quat.Rotation();
    const Vec3 local = rot.transpose() * normal;
    const Vec3 var = RelativeVariances(&model.log_scales[3 * i]);
    const T trace = var.sum();
    Mat3 d_rot;
    for (int k = 0; k < 3; ++k) {
      (*d_log_scales)[3 * i + k] +=
          scale * T(2) * var(k) * (local(k) * local(k) - f[i]) / trace;
      d_rot.col(k) = T(2) * var(k) * local(k) * normal / trace;
    }
    const Eigen::Matrix<T, 4, 1> d_q = quat.Backward(d_rot) * scale;
    for (int k = 0; k < 4; ++k) (*d_quats)[4 * i + k] += d_q(k);
  }
  return result;
}

template <typename T>
HiddenDepth HiddenDepthLoss(const GaussianModelT<T>& model, std::size_t first,
                            const RasterCameraT<T>& camera,
                            const std::vector<float>& depth,
                            const std::vector<std::uint8_t>& mask,
                            double weight, double thickness,
                            std::vector<T>* d_means) {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  const int w = camera.width, h = camera.height;
  const std::size_t n = model.size();
  const std::size_t pixels = static_cast<std::size_t>(w) * h;
  if (depth.size() != pixels || mask.size() != pixels) {
    throw Error(
        "hidden depth", "depth and mask",
        std::to_string(depth.size()) + ", " + std::to_string(mask.size()),
        "expected " + std::to_string(w) + " x " + std::to_string(h) +
            " values each (the camera's size)");
  }
  if (d_means->size() != n * 3) {
    throw Error("hidden depth", "gradients", std::to_string(d_means->size()),
                "expected an array sized like the model's " +
                    std::to_string(n) + " Gaussians");
  }
  HiddenDepth result;
  if (weight == 0 || first >= n) return result;

  // Per row: the hinge (0 when within the thickness, -1 when not a
  // candidate) and the depth it was measured against.
  std::vector<T> hinge(n, T(-1));
  std::vector<T> given(n, T(0));
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = static_cast<std::ptrdiff_t>(first);
       i < static_cast<std::ptrdiff_t>(n); ++i) {
    Vec3 t;
    int px, py;
    if (!CentrePixel(model, i, camera, &t, &px, &py)) continue;
    const std::size_t pixel = static_cast<std::size_t>(py) * w + px;
    const float d = depth[pixel];
    if (!mask[pixel] || !(d > 0)) continue;
    given[i] = T(d);
    hinge[i] = std::max(T(0), t.z() / T(d) - T(1) - T(thickness));
  }
  double sum = 0;
  for (std::size_t i = first; i < n; ++i) {
    if (hinge[i] < 0) continue;
    ++result.gaussians;
    result.hidden += hinge[i] > 0;
    sum += hinge[i];
  }
  if (result.gaussians == 0) return result;
  const double scale = weight / static_cast<double>(result.gaussians);
  result.loss = scale * sum;
  // dz/dmean is the camera's z axis in world coordinates.
  const Vec3 axis = camera.rotation.row(2).transpose();
  for (std::size_t i = first; i < n; ++i) {
    if (!(hinge[i] > 0)) continue;
    const T g = static_cast<T>(scale) / given[i];
    for (int k = 0; k < 3; ++k) (*d_means)[3 * i + k] += g * axis(k);
  }
  return result;
}

template bool DepthNormalAt(const std::vector<float>&,
                            const RasterCameraT<float>&, int, int,
                            Eigen::Matrix<float, 3, 1>*);
template bool DepthNormalAt(const std::vector<float>&,
                            const RasterCameraT<double>&, int, int,
                            Eigen::Matrix<double, 3, 1>*);
template NormalFlatness NormalFlatnessLoss(const GaussianModelT<float>&,
                                           const RasterCameraT<float>&,
                                           const std::vector<float>&, double,
                                           double, std::vector<float>*,
                                           std::vector<float>*);
template NormalFlatness NormalFlatnessLoss(const GaussianModelT<double>&,
                                           const RasterCameraT<double>&,
                                           const std::vector<float>&, double,
                                           double, std::vector<double>*,
                                           std::vector<double>*);
template HiddenDepth HiddenDepthLoss(const GaussianModelT<float>&, std::size_t,
                                     const RasterCameraT<float>&,
                                     const std::vector<float>&,
                                     const std::vector<std::uint8_t>&, double,
                                     double, std::vector<float>*);
template HiddenDepth HiddenDepthLoss(const GaussianModelT<double>&, std::size_t,
                                     const RasterCameraT<double>&,
                                     const std::vector<float>&,
                                     const std::vector<std::uint8_t>&, double,
                                     double, std::vector<double>*);

}  // namespace pano4d
