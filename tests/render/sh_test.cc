#include "src/render/sh.h"

#include <cmath>

#include <gtest/gtest.h>

namespace pano4d {
namespace {

// The real SH basis is orthonormal on the sphere: a wrong constant or sign
// pattern in any of the 16 functions shows up here. Fibonacci-sphere
// quadrature with 40,000 points.
TEST(ShTest, BasisIsOrthonormalOnTheSphere) {
  constexpr int kPoints = 40000;
  double gram[16][16] = {};
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < kPoints; ++i) {
    const double z = 1 - (2.0 * i + 1) / kPoints;
    const double r = std::sqrt(1 - z * z);
    const Eigen::Vector3f dir(static_cast<float>(r * std::cos(golden * i)),
                              static_cast<float>(r * std::sin(golden * i)),
                              static_cast<float>(z));
    float basis[16];
    ShBasis(3, dir, basis);
    for (int a = 0; a < 16; ++a) {
      for (int b = 0; b < 16; ++b)
        gram[a][b] += basis[a] * basis[b] * 4 * M_PI / kPoints;
    }
  }
  for (int a = 0; a < 16; ++a) {
    for (int b = 0; b < 16; ++b)
      EXPECT_NEAR(gram[a][b], a == b ? 1.0 : 0.0, 2e-3) << a << "," << b;
  }
}

TEST(ShTest, BasisGradientMatchesCentralDifferences) {
  const Eigen::Vector3d dir = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  double analytic[48];
  ShBasisGradient(3, dir, analytic);
  for (int a = 0; a < 3; ++a) {
    Eigen::Vector3d plus = dir, minus = dir;
    plus(a) += 1e-6;
    minus(a) -= 1e-6;
    double bp[16], bm[16];
    ShBasis(3, plus, bp);
    ShBasis(3, minus, bm);
    for (int k = 0; k < 16; ++k) {
      EXPECT_NEAR(analytic[3 * k + a], (bp[k] - bm[k]) / 2e-6, 1e-8)
          << "basis " << k << " axis " << a;
    }
  }
}

TEST(ShTest, ColourIsOffsetByAHalfAndClampedAtZero) {
  float coeffs[16 * 3] = {};
  coeffs[0] = 1.0f;   // red DC
  coeffs[1] = -4.0f;  // green DC: clamps
  const Eigen::Vector3f dir(0, 0, 1);
  bool clamped[3];
  const Eigen::Vector3f c = ShColor(0, coeffs, dir, clamped);
  EXPECT_NEAR(c.x(), 0.28209479177387814f + 0.5f, 1e-7);
  EXPECT_EQ(c.y(), 0.0f);
  EXPECT_TRUE(clamped[1]);
  EXPECT_FALSE(clamped[0]);
  EXPECT_NEAR(c.z(), 0.5f, 1e-7);
  // Degree 1 along +z uses the third coefficient only: C1 * z.
  coeffs[3 * 2] = 1.0f;
  EXPECT_NEAR(ShColor(1, coeffs, dir).x(),
              0.28209479177387814f + 0.4886025119029199f + 0.5f, 1e-6);
}

}  // namespace
}  // namespace pano4d
