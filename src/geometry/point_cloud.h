#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "src/core/posed_camera.h"

namespace pano4d {

// A coloured point cloud, structure of arrays (world coordinates, RGB in
// [0, 1]).
struct PointCloud {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> colors;
  std::size_t size() const { return points.size(); }
};

// Every `stride`-th pixel of a z-depth map (CV_32F, 0 or non-finite = none)
// lifted to the world through `camera` (pixel centres at +0.5), coloured
// from `rgb` (CV_32FC3, RGB in [0, 1], same size) when it is not empty.
// Pixels whose ray does not unproject are skipped. Throws pano4d::Error for
// a depth map of another size than the camera or a wrong type.
PointCloud UnprojectDepth(const cv::Mat& depth, const cv::Mat& rgb,
                          const PosedCamera& camera, int stride = 1);

struct PointCloudFilterOptions {
  // Statistical outlier removal (PCL): a point whose mean distance to its
  // `neighbours` nearest is more than `std_ratio` standard deviations above
  // the cloud's mean is dropped. 0 neighbours: no removal.
  int neighbours = 20;
  double std_ratio = 2.0;
  // Voxel-grid downsampling (PCL): one point (the centroid) per voxel of
  // this edge, in world units; 0: none.
  double voxel_size = 0.0;
  void Check() const;  // throws pano4d::Error naming the field
};

// Denoises and thins a cloud, as the blueprint's initialisation does.
PointCloud FilterPointCloud(const PointCloud& cloud,
                            const PointCloudFilterOptions& options);

// For each point, the mean distance to its k nearest other points (FLANN
// through PCL's KdTreeFLANN): 3DGS's initial Gaussian scale. Points with
// fewer than k others get the mean over those there are; a single point
// gets 0.
std::vector<float> MeanNeighbourDistance(const PointCloud& cloud, int k = 3);

// A plane n . x + offset = 0 (n a unit normal) and the points on it.
struct Plane {
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();
  float offset = 0;
  std::vector<std::size_t> inliers;  // indices into the cloud fitted
};

// The plane the most points of `cloud` lie within `threshold` of (RANSAC,
// PCL's, with a fixed seed: the same cloud gives the same plane; refitted
// to its inliers). nullopt when there is none (fewer than 3 points, all on
// a line). Throws pano4d::Error for a threshold that is not positive.
std::optional<Plane> FitDominantPlane(const PointCloud& cloud, double threshold,
                                      int max_iterations = 200);

}  // namespace pano4d
