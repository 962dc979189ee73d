#pragma once
// Internal to src/geometry: PCL behind plain arrays. pcl_bridge.cc is built
// with the baseline instruction set, like Debian's PCL, because PCL's
// classes hold Eigen members whose alignment depends on it (with
// -march=native the layouts differ and PCL crashes); nothing with Eigen
// types crosses this header.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pano4d::pcl_bridge {

// xyz: n x 3 floats. 1 = keep, per point (pcl::StatisticalOutlierRemoval).
std::vector<std::uint8_t> StatisticalOutlierMask(const float* xyz,
                                                 std::size_t n, int neighbours,
                                                 double std_ratio);

// Centroids of the occupied voxels (pcl::VoxelGrid), with the mean colour
// (rgb: n x 3 in [0, 1], or null).
void VoxelGrid(const float* xyz, const float* rgb, std::size_t n, float leaf,
               std::vector<float>* out_xyz, std::vector<float>* out_rgb);

// out[i]: mean distance from point i to its k nearest others
// (pcl::KdTreeFLANN); out has n entries.
void MeanNeighbourDistance(const float* xyz, std::size_t n, int k, float* out);

// The plane most points lie within `threshold` of (pcl::RandomSampleConsensus
// over pcl::SampleConsensusModelPlane, whose generator has a fixed seed: the
// same points give the same plane). coefficients: a, b, c, d of
// a x + b y + c z + d = 0 with (a, b, c) a unit normal; inliers: the indices
// of the points within `threshold`. Returns false when no plane was found
// (fewer than 3 points, or all on a line).
bool FitPlane(const float* xyz, std::size_t n, double threshold,
              int max_iterations, float coefficients[4],
              std::vector<int>* inliers);

}  // namespace pano4d::pcl_bridge
