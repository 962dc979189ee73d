#include "src/render/panorama.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "src/render/sh.h"

namespace pano4d {
namespace {

EquirectProjection Projection(int w = 64, int h = 32) {
  EquirectProjection p;
  p.center = Eigen::Vector3d(1, 2, 3);
  p.width = w;
  p.height = h;
  return p;
}

TEST(PanoramaTest, HandComputedDirections) {
  const EquirectProjection p = Projection();
  const Eigen::Vector3d c = p.center;
  EXPECT_LT((p.Project(c + Eigen::Vector3d(1, 0, 0)) - Eigen::Vector2d(32, 16))
                .norm(),
            1e-12);  // centre
  EXPECT_LT((p.Project(c + Eigen::Vector3d(0, 2, 0)) - Eigen::Vector2d(48, 16))
                .norm(),
            1e-12);  // phi = pi/2
  EXPECT_LT((p.Project(c + Eigen::Vector3d(0, -2, 0)) - Eigen::Vector2d(16, 16))
                .norm(),
            1e-12);
  EXPECT_NEAR(p.Project(c + Eigen::Vector3d(0, 0, 5)).y(), 0.0,
              1e-12);  // north pole: top row
  EXPECT_NEAR(p.Project(c + Eigen::Vector3d(0, 0, -5)).y(), 32.0,
              1e-12);  // south pole: bottom
  EXPECT_EQ(p.Pixel(p.Project(c + Eigen::Vector3d(0, 0, -5))).y(),
            31);  // rows clamp
  EXPECT_NEAR(p.Project(c + Eigen::Vector3d(1, 0, 1)).y(), 8.0,
              1e-12);  // 45 degrees up
  // The seam: just either side of -x lands in the first and last columns.
  EXPECT_EQ(p.Pixel(p.Project(c + Eigen::Vector3d(-1, 1e-9, 0))).x(), 63);
  EXPECT_EQ(p.Pixel(p.Project(c + Eigen::Vector3d(-1, -1e-9, 0))).x(), 0);
  EXPECT_EQ(p.Pixel(p.Project(c + Eigen::Vector3d(-1, 0, 0))).x(),
            0);  // phi = +pi wraps to 0
}

TEST(PanoramaTest, DirectionInvertsProjection) {
  EquirectProjection p = Projection(2048, 1024);
  p.r_align = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())
                  .toRotationMatrix();
  std::mt19937 rng(1);
  std::normal_distribution<double> n;
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector3d q(n(rng), n(rng), n(rng));
    const Eigen::Vector3d d = p.Direction(p.Project(p.center + 3.0 * q));
    EXPECT_LT((d - q.normalized()).norm(), 1e-12);
  }
}

TEST(PanoramaTest, SplatsWrapAcrossTheSeamAndWidenAtThePoles) {
  const EquirectProjection p = Projection(64, 32);
  const double pixel = 2 * M_PI / 64;
  const PanoramaImage seam =
      SplatPoints(p, {(p.center + Eigen::Vector3d(-2, 0, 0)).cast<float>()},
                  {Eigen::Vector3f(1, 0, 0)}, 2.5 * pixel);
  const auto lit = [](const PanoramaImage& image, int x, int y) {
    return image.distance[y * image.width + x] > 0;
  };
  EXPECT_TRUE(lit(seam, 0, 16) && lit(seam, 1, 16));
  EXPECT_TRUE(lit(seam, 63, 16) &&
              lit(seam, 62, 16));  // the other side of the seam
  EXPECT_FALSE(lit(seam, 32, 16));

  // Near the north pole a small disc covers many columns of the top rows.
  const PanoramaImage pole =
      SplatPoints(p, {(p.center + Eigen::Vector3d(0.01, 0, 2)).cast<float>()},
                  {Eigen::Vector3f(0, 1, 0)}, 3 * pixel);
  int top_row = 0;
  for (int x = 0; x < 64; ++x) top_row += lit(pole, x, 0);
  EXPECT_GT(top_row, 32);
  for (const float v : pole.rgb) EXPECT_TRUE(std::isfinite(v));
}

TEST(PanoramaTest, NearestPointWinsWhateverTheOrder) {
  const EquirectProjection p = Projection();
  const Eigen::Vector3f near =
      (p.center + Eigen::Vector3d(1, 0.1, 0)).cast<float>();
  const Eigen::Vector3f far =
      (p.center + Eigen::Vector3d(5, 0.5, 0)).cast<float>();  // same direction
  const Eigen::Vector3f red(1, 0, 0), blue(0, 0, 1);
  const PanoramaImage a = SplatPoints(p, {near, far}, {red, blue}, 0.1);
  const PanoramaImage b = SplatPoints(p, {far, near}, {blue, red}, 0.1);
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_EQ(a.distance, b.distance);
  const Eigen::Vector2i pixel = p.Pixel(p.Project(near.cast<double>()));
  const std::size_t i =
      static_cast<std::size_t>(pixel.y()) * p.width + pixel.x();
  EXPECT_EQ(a.rgb[3 * i], 1.0f);
  EXPECT_NEAR(a.distance[i], (near.cast<double>() - p.center).norm(), 1e-5);
}

TEST(PanoramaTest, GaussiansSplatWithTheirDcColour) {
  const EquirectProjection p = Projection();
  GaussianModel m;
  m.Resize(1);
  m.means = {static_cast<float>(p.center.x() + 2),
             static_cast<float>(p.center.y()),
             static_cast<float>(p.center.z())};
  m.log_scales = {std::log(0.2f), std::log(0.2f), std::log(0.2f)};
  m.quats = {1, 0, 0, 0};
  m.opacities = {0};
  m.sh = {(0.8f - 0.5f) / static_cast<float>(kShC0), 0, 0};
  const PanoramaImage image = SplatGaussians(p, m);
  const std::size_t centre = 16 * 64 + 32;
  EXPECT_NEAR(image.rgb[3 * centre], 0.8f, 1e-6);
  EXPECT_NEAR(image.distance[centre], 2.0f, 1e-5);
}

}  // namespace
}  // namespace pano4d
