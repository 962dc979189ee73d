#include "src/render/sh.h"

namespace pano4d {
namespace {

constexpr float kC0 = 0.28209479177387814f;
constexpr float kC1 = 0.4886025119029199f;
constexpr float kC2[] = {1.0925484305920792f, -1.0925484305920792f,
                         0.31539156525252005f, -1.0925484305920792f,
                         0.5462742152960396f};
constexpr float kC3[] = {-0.5900435899266435f, 2.890611442640554f,
                         -0.4570457994644658f, 0.3731763325901154f,
                         -0.4570457994644658f, 1.445305721320277f,
                         -0.5900435899266435f};

}  // namespace

void ShBasis(int degree, const Eigen::Vector3f& dir, float* b) {
  b[0] = kC0;
  if (degree < 1) return;
  const float x = dir.x(), y = dir.y(), z = dir.z();
  b[1] = -kC1 * y;
  b[2] = kC1 * z;
  b[3] = -kC1 * x;
  if (degree < 2) return;
  const float xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z,
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

Eigen::Vector3f ShColor(int degree, const float* coeffs,
                        const Eigen::Vector3f& dir, bool* clamped) {
  float basis[16];
  ShBasis(degree, dir, basis);
  const int k_count = (degree + 1) * (degree + 1);
  Eigen::Vector3f color(0.5f, 0.5f, 0.5f);
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

}  // namespace pano4d
