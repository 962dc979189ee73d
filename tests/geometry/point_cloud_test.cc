#include "src/geometry/point_cloud.h"

#include <random>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

PosedCamera TestCamera() {
  PosedCamera c;
  c.camera = {CameraModelId::kPinhole, 40, 30, {50, 50, 20, 15}};
  c.cam_from_world = Rigid3d(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())),
      {0.2, -0.1, 0.5});
  return c;
}

TEST(PointCloudTest, UnprojectedPointsProjectBackToTheirPixelsAndDepth) {
  const PosedCamera camera = TestCamera();
  cv::Mat depth(30, 40, CV_32F, cv::Scalar(2.5f));
  depth.at<float>(3, 4) = 0;  // no depth: skipped
  cv::Mat rgb(30, 40, CV_32FC3, cv::Scalar(0.1f, 0.5f, 0.9f));
  const PointCloud cloud = UnprojectDepth(depth, rgb, camera, 1);
  ASSERT_EQ(cloud.size(), 40u * 30u - 1);
  ASSERT_EQ(cloud.colors.size(), cloud.size());
  EXPECT_FLOAT_EQ(cloud.colors[0].y(), 0.5f);
  // Row-major order: point 0 is pixel (0, 0).
  const Eigen::Vector3d p0 = cloud.points[0].cast<double>();
  EXPECT_NEAR((camera.cam_from_world * p0).z(), 2.5, 1e-5);
  const auto pixel = camera.Project(p0);
  ASSERT_TRUE(pixel.has_value());
  EXPECT_NEAR(pixel->x(), 0.5, 1e-4);
  EXPECT_NEAR(pixel->y(), 0.5, 1e-4);
  EXPECT_EQ(UnprojectDepth(depth, cv::Mat(), camera, 2).size(), 20u * 15u);
  EXPECT_THROW(UnprojectDepth(cv::Mat(10, 10, CV_32F), rgb, camera), Error);
}

// A 10 x 10 x 10 grid with spacing 0.1, plus far outliers.
PointCloud GridWithOutliers(int outliers) {
  PointCloud cloud;
  for (int x = 0; x < 10; ++x)
    for (int y = 0; y < 10; ++y)
      for (int z = 0; z < 10; ++z)
        cloud.points.emplace_back(0.1f * x, 0.1f * y, 0.1f * z);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(5, 10);
  for (int i = 0; i < outliers; ++i)
    cloud.points.emplace_back(u(rng), u(rng), u(rng));
  return cloud;
}

TEST(PointCloudTest, StatisticalOutlierRemovalDropsFarPoints) {
  const PointCloud cloud = GridWithOutliers(20);
  const PointCloud kept = FilterPointCloud(cloud, {});
  EXPECT_GE(kept.size(), 950u);  // the grid stays (its border may thin)
  for (const Eigen::Vector3f& p : kept.points)
    EXPECT_LT(p.maxCoeff(), 1.0f) << "an outlier survived";
}

TEST(PointCloudTest, VoxelGridThinsTheCloud) {
  const PointCloud cloud = GridWithOutliers(0);
  PointCloudFilterOptions options;
  options.neighbours = 0;
  options.voxel_size = 0.2;
  const PointCloud thinned = FilterPointCloud(cloud, options);
  EXPECT_EQ(thinned.size(), 125u);  // 2 x 2 x 2 grid points per voxel
}

TEST(PointCloudTest, MeanNeighbourDistanceOfAGridIsItsSpacing) {
  const PointCloud cloud = GridWithOutliers(0);
  const std::vector<float> d = MeanNeighbourDistance(cloud, 3);
  ASSERT_EQ(d.size(), cloud.size());
  // An interior point's 3 nearest are all at 0.1.
  EXPECT_NEAR(d[5 * 100 + 5 * 10 + 5], 0.1f, 1e-5);
  for (const float v : d) EXPECT_NEAR(v, 0.1f, 1e-5);
  PointCloud one;
  one.points.emplace_back(0, 0, 0);
  EXPECT_EQ(MeanNeighbourDistance(one, 3)[0], 0.0f);
  EXPECT_THROW(MeanNeighbourDistance(one, 0), Error);
}

TEST(PointCloudTest, TheDominantPlaneIsFoundAmongClutter) {
  // 600 points on the tilted plane n . x = 1.5 with 1 cm of noise, and 300
  // scattered through a cube: RANSAC finds the plane, and its inliers are
  // the plane's points.
  const Eigen::Vector3f n = Eigen::Vector3f(0.2f, -0.3f, 1.0f).normalized();
  const Eigen::Vector3f u = n.unitOrthogonal(), v = n.cross(u);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> wide(-2, 2);
  std::normal_distribution<float> noise(0, 0.01f);
  PointCloud cloud;
  for (int i = 0; i < 600; ++i)
    cloud.points.push_back(1.5f * n + wide(rng) * u + wide(rng) * v +
                           noise(rng) * n);
  for (int i = 0; i < 300; ++i)
    cloud.points.emplace_back(wide(rng), wide(rng), wide(rng) + 4);
  const std::optional<Plane> plane = FitDominantPlane(cloud, 0.05);
  ASSERT_TRUE(plane.has_value());
  EXPECT_GT(std::abs(plane->normal.dot(n)), 0.999f);
  EXPECT_NEAR(std::abs(plane->offset), 1.5f, 0.01f);
  std::size_t on_plane = 0;
  for (const std::size_t i : plane->inliers) on_plane += i < 600;
  EXPECT_GE(on_plane, 590u);
  EXPECT_LE(plane->inliers.size() - on_plane, 20u);
  // The same cloud, the same plane (PCL's generator has a fixed seed).
  const std::optional<Plane> again = FitDominantPlane(cloud, 0.05);
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(again->inliers, plane->inliers);
  EXPECT_EQ(again->normal, plane->normal);
}

TEST(PointCloudTest, APlaneFitNeedsThreePointsAndAPositiveBand) {
  PointCloud two;
  two.points = {Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX()};
  EXPECT_FALSE(FitDominantPlane(two, 0.1).has_value());
  EXPECT_THROW(FitDominantPlane(two, 0.0), Error);
}

}  // namespace
}  // namespace pano4d
