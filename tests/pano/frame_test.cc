#include "src/pano/frame.h"

#include <cmath>

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "tests/pano/look_at.h"

namespace pano4d {
namespace {

using testing::LookAt;

TEST(PanoramaFrameTest, CentreIsTheCentroidAndTheFirstViewMapsToTheMiddle) {
  const std::vector<Eigen::Vector3f> points = {
      {0, 0, 0}, {2, 0, 0}, {0, 4, 0}, {2, 4, 2}};
  const std::vector<RasterCamera> cameras = {
      LookAt({1, -5, 0.5f}, {1, 2, 0.5f}), LookAt({3, -5, 0.5f}, {1, 2, 0.5f})};
  const PanoramaFrame f = MakePanoramaFrame(points, cameras);
  EXPECT_LT((f.center - Eigen::Vector3d(1, 2, 0.5)).norm(), 1e-9);
  EXPECT_LT(
      (f.r_align.transpose() * f.r_align - Eigen::Matrix3d::Identity()).norm(),
      1e-9);
  EXPECT_NEAR(f.r_align.determinant(), 1.0, 1e-9);
  // Up is world +z (both cameras look level); the first camera's view,
  // levelled, is the panorama's +x: a point ahead of it lands in the middle
  // column, and world up at the top row.
  EXPECT_LT((f.r_align.col(2) - Eigen::Vector3d::UnitZ()).norm(), 1e-6);
  const EquirectProjection p = f.Projection(360, 180);
  const Eigen::Vector2d ahead =
      p.Project(f.center + Eigen::Vector3d(0, 1, 0));  // camera 0 looks +y
  EXPECT_NEAR(ahead.x(), 180.0, 1e-6);
  EXPECT_NEAR(ahead.y(), 90.0, 1e-6);
  EXPECT_NEAR(p.Project(f.center + Eigen::Vector3d(0, 0, 3)).y(), 0.0, 1e-6);
  // Behind the first camera: the seam.
  const Eigen::Vector2d behind =
      p.Project(f.center + Eigen::Vector3d(1e-9, -1, 0));
  EXPECT_TRUE(behind.x() < 1e-3 || behind.x() > 360 - 1e-3) << behind.x();
}

// A camera with the given viewing and up directions (orthogonal, unit).
RasterCamera FromAxes(const Eigen::Vector3f& forward,
                      const Eigen::Vector3f& up) {
  RasterCamera c = LookAt({0, -5, 0}, {0, 0, 0});
  const Eigen::Vector3f down = -up;
  c.rotation.row(0) = down.cross(forward).transpose();
  c.rotation.row(1) = down.transpose();
  c.rotation.row(2) = forward.transpose();
  return c;
}

TEST(PanoramaFrameTest, RefusesWhatHasNoFrame) {
  const RasterCamera c = LookAt({0, -5, 0}, {0, 0, 0});
  EXPECT_THROW(MakePanoramaFrame({}, {c}), Error);
  EXPECT_THROW(MakePanoramaFrame({{0, 0, 0}}, {}), Error);
  EXPECT_THROW(MakePanoramaFrame({{0, 0, NAN}}, {c}), Error);
  // Up vectors that cancel.
  const RasterCamera a = FromAxes({1, 0, 0}, {0, 0, 1});
  const RasterCamera b = FromAxes({1, 0, 0}, {0, 0, -1});
  EXPECT_THROW(MakePanoramaFrame({{0, 0, 0}}, {a, b}), Error);
  // The first camera looks straight along the mean up (+z).
  const Eigen::Vector3f tilted(0, -0.5f, std::sqrt(3.0f) / 2);
  const RasterCamera up_looking = FromAxes({0, 0, 1}, {0, 1, 0});
  const RasterCamera other = FromAxes({1, 0, 0}, tilted);
  EXPECT_THROW(MakePanoramaFrame({{0, 0, 0}}, {up_looking, other, other}),
               Error);
  EXPECT_NO_THROW(MakePanoramaFrame({{0, 0, 0}}, {other, up_looking, other}));
}

}  // namespace
}  // namespace pano4d
