#include "src/render/sh.h"

namespace pano4d {
namespace {

constexpr double kC0 = 0.28209479177387814;
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
  b[0] = kC0;
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

template void ShBasis<float>(int, const Eigen::Matrix<float, 3, 1>&, float*);
template void ShBasis<double>(int, const Eigen::Matrix<double, 3, 1>&, double*);
template Eigen::Matrix<float, 3, 1> ShColor<float>(
    int, const float*, const Eigen::Matrix<float, 3, 1>&, bool*);
template Eigen::Matrix<double, 3, 1> ShColor<double>(
    int, const double*, const Eigen::Matrix<double, 3, 1>&, bool*);

}  // namespace pano4d
