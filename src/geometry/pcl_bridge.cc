#include "src/geometry/pcl_bridge.h"

#include <algorithm>
#include <cmath>

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_plane.h>

namespace pano4d::pcl_bridge {
namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr Cloud(const float* xyz, std::size_t n) {
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(n);
  for (std::size_t i = 0; i < n; ++i)
    cloud->emplace_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  return cloud;
}

}  // namespace

std::vector<std::uint8_t> StatisticalOutlierMask(const float* xyz,
                                                 std::size_t n, int neighbours,
                                                 double std_ratio) {
  pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
  sor.setInputCloud(Cloud(xyz, n));
  sor.setMeanK(neighbours);
  sor.setStddevMulThresh(std_ratio);
  pcl::Indices kept;
  sor.filter(kept);
  std::vector<std::uint8_t> mask(n, 0);
  for (const auto i : kept) mask[static_cast<std::size_t>(i)] = 1;
  return mask;
}

void VoxelGrid(const float* xyz, const float* rgb, std::size_t n, float leaf,
               std::vector<float>* out_xyz, std::vector<float>* out_rgb) {
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZRGB>>();
  cloud->reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    pcl::PointXYZRGB p;
    p.x = xyz[3 * i];
    p.y = xyz[3 * i + 1];
    p.z = xyz[3 * i + 2];
    const auto channel = [&](int c) {
      const float v = rgb ? std::clamp(rgb[3 * i + c], 0.0f, 1.0f) : 0.0f;
      return static_cast<std::uint8_t>(std::lround(255 * v));
    };
    p.r = channel(0);
    p.g = channel(1);
    p.b = channel(2);
    cloud->push_back(p);
  }
  pcl::VoxelGrid<pcl::PointXYZRGB> grid;
  grid.setInputCloud(cloud);
  grid.setLeafSize(leaf, leaf, leaf);
  pcl::PointCloud<pcl::PointXYZRGB> filtered;
  grid.filter(filtered);
  out_xyz->clear();
  out_rgb->clear();
  for (const pcl::PointXYZRGB& p : filtered) {
    out_xyz->insert(out_xyz->end(), {p.x, p.y, p.z});
    out_rgb->insert(out_rgb->end(), {p.r / 255.0f, p.g / 255.0f, p.b / 255.0f});
  }
}

void MeanNeighbourDistance(const float* xyz, std::size_t n, int k, float* out) {
  std::fill(out, out + n, 0.0f);
  if (n < 2) return;
  const auto cloud = Cloud(xyz, n);
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  const int wanted = static_cast<int>(std::min<std::size_t>(k + 1, n));
  pcl::Indices ids(wanted);
  std::vector<float> squared(wanted);
  for (std::size_t i = 0; i < n; ++i) {
    const int found = tree.nearestKSearch((*cloud)[i], wanted, ids, squared);
    // The point itself comes back among its neighbours: skip it once.
    double sum = 0;
    int used = 0;
    bool skipped_self = false;
    for (int j = 0; j < found && used < k; ++j) {
      if (!skipped_self && ids[j] == static_cast<pcl::index_t>(i)) {
        skipped_self = true;
        continue;
      }
      sum += std::sqrt(squared[j]);
      ++used;
    }
    out[i] = used > 0 ? static_cast<float>(sum / used) : 0.0f;
  }
}

bool FitPlane(const float* xyz, std::size_t n, double threshold,
              int max_iterations, float coefficients[4],
              std::vector<int>* inliers) {
  inliers->clear();
  if (n < 3) return false;
  const auto model =
      std::make_shared<pcl::SampleConsensusModelPlane<pcl::PointXYZ>>(
          Cloud(xyz, n));
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, threshold);
  ransac.setMaxIterations(max_iterations);
  if (!ransac.computeModel()) return false;
  pcl::Indices found;
  ransac.getInliers(found);
  Eigen::VectorXf c;
  ransac.getModelCoefficients(c);
  if (found.size() < 3 || c.size() != 4) return false;
  // Refit to every inlier (least squares), as PCL's SACSegmentation does.
  Eigen::VectorXf refined;
  model->optimizeModelCoefficients(found, c, refined);
  const float norm = refined.head<3>().norm();
  if (!(norm > 0) || !std::isfinite(norm)) return false;
  for (int i = 0; i < 4; ++i) coefficients[i] = refined[i] / norm;
  model->selectWithinDistance(refined / norm, threshold, found);
  inliers->assign(found.begin(), found.end());
  return true;
}

}  // namespace pano4d::pcl_bridge
