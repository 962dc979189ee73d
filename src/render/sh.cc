#include "src/render/sh.h"

namespace pano4d {
namespace {

constexpr double kC1 = 0.4886025119029199;
constexpr double kC2[] = {1.0925484305920792, -1.0925484305920792,
                          0.31539156525252005, -1.0925484305920792,
                          0.5462742152960396};
constexpr double kC3[] = {-0.5900435899266435, 2.890611442640554,
                          -0.4570457994644658, 0.3731763325901154,
                          -0.4570457994644658, 1.445305721320277,
                          -0.5900435899266435};

}  // namespace

template <typename T>
void ShBasis(int degree, const Eigen::Matrix<T, 3, 1>& dir, T* b) {
  b[0] = kShC0;
  if (degree < 1) return;
  const T x = dir.x(), y = dir.y(), z = dir.z();
  b[1] = -kC1 * y;
  b[2] = kC1 * z;
  b[3] = -kC1 * x;
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z,
          xz = x * z;
  b[4] = kC2[0] * xy;
  b[5] = kC2[1] * yz;
  b[6] = kC2[2] * (2 * zz - xx - yy);
  b[7] = kC2[3] * xz;
  b[8] = kC2[4] * (xx - yy);
  if (degree < 3) return;
  b[9] = kC3[0] * y * (3 * xx - yy);
  b[10] = kC3[1] * xy * z;
  b[11] = kC3[2] * y * (4 * zz - xx - yy);
  b[12] = kC3[3] * z * (2 * zz - 3 * xx - 3 * yy);
  b[13] = kC3[4] * x * (4 * zz - xx - yy);
  b[14] = kC3[5] * z * (xx - yy);
  b[15] = kC3[6] * x * (xx - 3 * yy);
}

template <typename T>
void ShBasisGradient(int degree, const Eigen::Matrix<T, 3, 1>& dir, T* d) {
  const int k_count = (degree + 1) * (degree + 1);
  for (int i = 0; i < 3 * k_count; ++i) d[i] = T(0);
  if (degree < 1) return;
  const T x = dir.x(), y = dir.y(), z = dir.z();
  const auto set = [&](int k, T dx, T dy, T dz) {
    d[3 * k] = dx;
    d[3 * k + 1] = dy;
    d[3 * k + 2] = dz;
  };
  set(1, 0, -kC1, 0);
  set(2, 0, 0, kC1);
  set(3, -kC1, 0, 0);
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z;
  set(4, kC2[0] * y, kC2[0] * x, 0);
  set(5, 0, kC2[1] * z, kC2[1] * y);
  set(6, -2 * kC2[2] * x, -2 * kC2[2] * y, 4 * kC2[2] * z);
  set(7, kC2[3] * z, 0, kC2[3] * x);
  set(8, 2 * kC2[4] * x, -2 * kC2[4] * y, 0);
  if (degree < 3) return;
  set(9, 6 * kC3[0] * x * y, kC3[0] * (3 * xx - 3 * yy), 0);
  set(10, kC3[1] * y * z, kC3[1] * x * z, kC3[1] * x * y);
  set(11, -2 * kC3[2] * x * y, kC3[2] * (4 * zz - xx - 3 * yy),
      8 * kC3[2] * y * z);
  set(12, -6 * kC3[3] * x * z, -6 * kC3[3] * y * z,
      kC3[3] * (6 * zz - 3 * xx - 3 * yy));
  set(13, kC3[4] * (4 * zz - 3 * xx - yy), -2 * kC3[4] * x * y,
      8 * kC3[4] * x * z);
  set(14, 2 * kC3[5] * x * z, -2 * kC3[5] * y * z, kC3[5] * (xx - yy));
  set(15, kC3[6] * (3 * xx - 3 * yy), -6 * kC3[6] * x * y, 0);
}

template <typename T>
Eigen::Matrix<T, 3, 1> ShColor(int degree, const T* coeffs,
                               const Eigen::Matrix<T, 3, 1>& dir,
                               bool* clamped) {
  T basis[16];
  ShBasis(degree, dir, basis);
  const int k_count = (degree + 1) * (degree + 1);
  Eigen::Matrix<T, 3, 1> color(T(0.5), T(0.5), T(0.5));
  for (int k = 0; k < k_count; ++k) {
    color.x() += basis[k] * coeffs[3 * k];
    color.y() += basis[k] * coeffs[3 * k + 1];
    color.z() += basis[k] * coeffs[3 * k + 2];
  }
  for (int c = 0; c < 3; ++c) {
    if (clamped) clamped[c] = color(c) < 0;
    color(c) = color(c) < 0 ? 0 : color(c);
  }
  return color;
}

template <typename T>
Eigen::Matrix<T, 3, 1> ShColorVjp(int degree, const T* coeffs,
                                  const Eigen::Matrix<T, 3, 1>& view,
                                  const T* d_color, T* d_coeffs) {
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  const Vec3 dir = view.normalized();
  T basis[16], d_basis[48];
  ShBasis(degree, dir, basis);
  ShBasisGradient(degree, dir, d_basis);
  const int k_count = (degree + 1) * (degree + 1);
  Vec3 d_dir = Vec3::Zero();
  for (int k = 0; k < k_count; ++k) {
    for (int c = 0; c < 3; ++c) {
      d_coeffs[3 * k + c] = basis[k] * d_color[c];
      d_dir += Vec3(d_basis[3 * k], d_basis[3 * k + 1], d_basis[3 * k + 2]) *
               coeffs[3 * k + c] * d_color[c];
    }
  }
  // Through the normalisation dir = view / |view|.
  return (Eigen::Matrix<T, 3, 3>::Identity() - dir * dir.transpose()) * d_dir /
         view.norm();
}

template void ShBasis<float>(int, const Eigen::Matrix<float, 3, 1>&, float*);
template void ShBasis<double>(int, const Eigen::Matrix<double, 3, 1>&, double*);
template void ShBasisGradient<float>(int, const Eigen::Matrix<float, 3, 1>&,
                                     float*);
template void ShBasisGradient<double>(int, const Eigen::Matrix<double, 3, 1>&,
                                      double*);
template Eigen::Matrix<float, 3, 1> ShColor<float>(
    int, const float*, const Eigen::Matrix<float, 3, 1>&, bool*);
template Eigen::Matrix<double, 3, 1> ShColor<double>(
    int, const double*, const Eigen::Matrix<double, 3, 1>&, bool*);
template Eigen::Matrix<float, 3, 1> ShColorVjp<float>(
    int, const float*, const Eigen::Matrix<float, 3, 1>&, const float*, float*);
template Eigen::Matrix<double, 3, 1> ShColorVjp<double>(
    int, const double*, const Eigen::Matrix<double, 3, 1>&, const double*,
    double*);

}  // namespace pano4d
