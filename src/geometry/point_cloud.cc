#include "src/geometry/point_cloud.h"

#include <cmath>
#include <string>

#include "src/core/error.h"
#include "src/core/option_checks.h"
#include "src/core/strings.h"
#include "src/geometry/pcl_bridge.h"

namespace pano4d {

// The bridge takes points as packed float triples.
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float));

PointCloud UnprojectDepth(const cv::Mat& depth, const cv::Mat& rgb,
                          const PosedCamera& camera, int stride) {
  const Camera& c = camera.camera;
  if (depth.type() != CV_32FC1 || depth.cols != c.width ||
      depth.rows != c.height) {
    throw Error("unproject", "depth", SizeText(depth.cols, depth.rows),
                "expected a CV_32F map of the camera's size " +
                    SizeText(c.width, c.height));
  }
  if (!rgb.empty() && (rgb.type() != CV_32FC3 || rgb.size() != depth.size()))
    throw Error("unproject", "rgb", "",
                "expected CV_32FC3 of the depth's size");
  if (stride < 1)
    throw Error("unproject", "stride", std::to_string(stride), "must be >= 1");
  PointCloud cloud;
  const Rigid3d world_from_cam = camera.cam_from_world.Inverse();
  for (int v = 0; v < depth.rows; v += stride) {
    for (int u = 0; u < depth.cols; u += stride) {
      const float z = depth.at<float>(v, u);
      if (!(z > 0) || !std::isfinite(z)) continue;
      const UnprojectResult r = c.Unproject({u + 0.5, v + 0.5});
      if (!r.ok()) continue;
      // The ray has unit length; z-depth scales it by z / ray.z.
      const Eigen::Vector3d point_cam = r.ray * (z / r.ray.z());
      cloud.points.push_back((world_from_cam * point_cam).cast<float>());
      if (!rgb.empty()) {
        const cv::Vec3f& color = rgb.at<cv::Vec3f>(v, u);
        cloud.colors.emplace_back(color[0], color[1], color[2]);
      }
    }
  }
  return cloud;
}

void PointCloudFilterOptions::Check() const {
  CheckNonNegative(neighbours, "point cloud filter", "neighbours");
  CheckPositive(std_ratio, "point cloud filter", "std_ratio");
  CheckNonNegative(voxel_size, "point cloud filter", "voxel_size");
}

PointCloud FilterPointCloud(const PointCloud& cloud,
                            const PointCloudFilterOptions& options) {
  options.Check();
  const bool colored = cloud.colors.size() == cloud.size();
  PointCloud current = cloud;
  if (options.neighbours > 0 &&
      static_cast<int>(current.size()) > options.neighbours) {
    const std::vector<std::uint8_t> keep = pcl_bridge::StatisticalOutlierMask(
        current.points.front().data(), current.size(), options.neighbours,
        options.std_ratio);
    PointCloud kept;
    for (std::size_t i = 0; i < current.size(); ++i) {
      if (!keep[i]) continue;
      kept.points.push_back(current.points[i]);
      if (colored) kept.colors.push_back(current.colors[i]);
    }
    current = std::move(kept);
  }
  if (options.voxel_size > 0 && current.size() > 0) {
    std::vector<float> xyz, rgb;
    pcl_bridge::VoxelGrid(current.points.front().data(),
                          colored ? current.colors.front().data() : nullptr,
                          current.size(),
                          static_cast<float>(options.voxel_size), &xyz, &rgb);
    PointCloud thinned;
    for (std::size_t i = 0; i < xyz.size() / 3; ++i) {
      thinned.points.emplace_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
      if (colored)
        thinned.colors.emplace_back(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
    }
    current = std::move(thinned);
  }
  return current;
}

std::vector<float> MeanNeighbourDistance(const PointCloud& cloud, int k) {
  if (k < 1)
    throw Error("neighbour distance", "k", std::to_string(k), "must be >= 1");
  std::vector<float> out(cloud.size(), 0.0f);
  if (cloud.size() < 2) return out;
  pcl_bridge::MeanNeighbourDistance(cloud.points.front().data(), cloud.size(),
                                    k, out.data());
  return out;
}

std::optional<Plane> FitDominantPlane(const PointCloud& cloud, double threshold,
                                      int max_iterations) {
  CheckPositive(threshold, "plane fit", "threshold");
  CheckPositive(max_iterations, "plane fit", "max_iterations");
  if (cloud.size() < 3) return std::nullopt;
  float c[4];
  std::vector<int> inliers;
  if (!pcl_bridge::FitPlane(cloud.points.front().data(), cloud.size(),
                            threshold, max_iterations, c, &inliers))
    return std::nullopt;
  Plane plane;
  plane.normal = Eigen::Vector3f(c[0], c[1], c[2]);
  plane.offset = c[3];
  plane.inliers.assign(inliers.begin(), inliers.end());
  return plane;
}

}  // namespace pano4d
