#include "src/render/blend_kernel.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace pano4d {
namespace {

// The float exp of the blend against the double library exp, densely over
// the range alpha needs (a Gaussian's exponent down to exp's floor).
TEST(BlendKernelTest, FloatExpIsWithinFourUlpOfTheLibrary) {
  double worst = 0;
  for (int i = 0; i <= 2000000; ++i) {
    const float x = -87.0f * static_cast<float>(i) / 2000000.0f;
    const double exact = std::exp(static_cast<double>(x));
    worst = std::max(worst, std::abs(ExpNonPositive(x) - exact) / exact);
  }
  EXPECT_LT(worst, 4 * std::numeric_limits<float>::epsilon()) << worst;
  EXPECT_EQ(ExpNonPositive(0.0f), 1.0f);
}

TEST(BlendKernelTest, FloatExpBelowTheFloorIsTinyAndFinite) {
  for (const float x :
       {-87.5f, -1e3f, -1e30f, -std::numeric_limits<float>::infinity()}) {
    const float e = ExpNonPositive(x);
    EXPECT_TRUE(std::isfinite(e)) << x;
    EXPECT_GE(e, 0.0f) << x;
    EXPECT_LT(e, 1e-37f) << x;
  }
}

TEST(BlendKernelTest, AlphaIsZeroBelowTheThresholdAndClampedAbove) {
  const ConicRow<float> row(1.0f, 0.0f, 1.0f, 0.0f);  // exp(-dx^2 / 2)
  // At the mean: raw = opacity.
  EXPECT_FLOAT_EQ(EvaluateAlpha(row, 0.5f, 0.0f).alpha, 0.5f);
  EXPECT_FLOAT_EQ(EvaluateAlpha(row, 1.0f, 0.0f).alpha, kMaxAlpha);
  EXPECT_FLOAT_EQ(EvaluateAlpha(row, 1.0f, 0.0f).raw, 1.0f);
  // raw just under and just over kMinAlpha, 3 px from the mean.
  const float at3 = std::exp(-4.5f);
  EXPECT_EQ(EvaluateAlpha(row, 0.99f * kMinAlpha / at3, 3.0f).alpha, 0.0f);
  EXPECT_GT(EvaluateAlpha(row, 1.01f * kMinAlpha / at3, 3.0f).alpha, 0.0f);
  // Far outside the ellipse: no overflow, no contribution.
  EXPECT_EQ(EvaluateAlpha(row, 1.0f, 1e20f).alpha, 0.0f);
}

TEST(BlendKernelTest, ExponentRoundedAboveZeroIsClampedNotDropped) {
  // An indefinite "conic" gives a positive exponent: a stand-in for the
  // rounding that can push a positive-definite one a hair above 0.
  const ConicRow<float> row(-1e-6f, 0.0f, 0.0f, 0.0f);
  const PixelAlpha<float> a = EvaluateAlpha(row, 0.5f, 1.0f);
  EXPECT_EQ(a.gauss, 1.0f);
  EXPECT_EQ(a.alpha, 0.5f);
}

TEST(BlendKernelTest, BoxCoversEveryPixelWhereAlphaReachesTheThreshold) {
  // One anisotropic, rotated Gaussian projected by hand.
  ProjectedGaussians p;
  p.Resize(1);
  const float cov_xx = 9.0f, cov_xy = 4.0f, cov_yy = 4.0f;
  const float det = cov_xx * cov_yy - cov_xy * cov_xy;
  p.x[0] = 20.3f;
  p.y[0] = 17.8f;
  p.conic_a[0] = cov_yy / det;
  p.conic_b[0] = -cov_xy / det;
  p.conic_c[0] = cov_xx / det;
  p.opacity[0] = 0.8f;
  const float k = 2 * std::log(p.opacity[0] / kMinAlpha);
  p.extent_x[0] = std::sqrt(k * cov_xx) + kAlphaBoxMargin;
  p.extent_y[0] = std::sqrt(k * cov_yy) + kAlphaBoxMargin;
  int inside = 0;
  for (int y_begin = 0; y_begin < 48; y_begin += kTileSize) {
    for (int x_begin = 0; x_begin < 48; x_begin += kTileSize) {
      TileBox box;
      const bool any = BoxInTile(p, 0, x_begin, x_begin + kTileSize, y_begin,
                                 y_begin + kTileSize, &box);
      for (int py = y_begin; py < y_begin + kTileSize; ++py) {
        const ConicRow<float> row(p.conic_a[0], p.conic_b[0], p.conic_c[0],
                                  py + 0.5f - p.y[0]);
        for (int px = x_begin; px < x_begin + kTileSize; ++px) {
          if (EvaluateAlpha(row, p.opacity[0], px + 0.5f - p.x[0]).alpha == 0)
            continue;
          ++inside;
          const int group = (px - x_begin) / kLaneGroup;
          ASSERT_TRUE(any && py >= box.y0 && py <= box.y1 &&
                      group >= box.group0 && group <= box.group1)
              << "pixel (" << px << ", " << py << ") outside the box";
        }
      }
    }
  }
  EXPECT_GT(inside, 50);
}

}  // namespace
}  // namespace pano4d
