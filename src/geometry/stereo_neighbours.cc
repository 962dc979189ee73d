#include "src/geometry/stereo_neighbours.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "src/core/error.h"

namespace pano4d {

void StereoNeighbourOptions::Check() const {
  if (neighbours < 1) {
    throw Error("stereo neighbours", "neighbours", std::to_string(neighbours),
                "must be at least 1");
  }
  if (!(baseline_ratio > 0) || !(min_baseline_ratio >= 0) ||
      !(min_baseline_ratio <= baseline_ratio)) {
    throw Error("stereo neighbours", "baseline_ratio",
                std::to_string(baseline_ratio),
                "must be positive and at least min_baseline_ratio (" +
                    std::to_string(min_baseline_ratio) + ")");
  }
  if (!(max_angle_degrees > 0 && max_angle_degrees <= 180)) {
    throw Error("stereo neighbours", "max_angle_degrees",
                std::to_string(max_angle_degrees), "must be in (0, 180]");
  }
}

std::vector<std::size_t> SelectStereoNeighbours(
    const std::vector<PosedCamera>& cameras, std::size_t reference,
    double median_depth, const StereoNeighbourOptions& o) {
  o.Check();
  if (reference >= cameras.size() || !(median_depth > 0)) {
    throw Error("stereo neighbours", "reference",
                std::to_string(reference) + " at median depth " +
                    std::to_string(median_depth),
                "needs a camera of the list and a positive depth");
  }
  const PosedCamera& ref = cameras[reference];
  const Eigen::Vector3d c = ref.Center();
  const Eigen::Vector3d axis =
      ref.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ();
  std::vector<std::pair<double, std::size_t>> candidates;
  for (std::size_t j = 0; j < cameras.size(); ++j) {
    if (j == reference) continue;
    const PosedCamera& other = cameras[j];
    const double ratio = (other.Center() - c).norm() / median_depth;
    const Eigen::Vector3d other_axis =
        other.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ();
    const double angle =
        std::acos(std::clamp(axis.dot(other_axis), -1.0, 1.0)) * 180 / M_PI;
    if (ratio < o.min_baseline_ratio || angle > o.max_angle_degrees) continue;
    candidates.push_back({std::abs(std::log(ratio / o.baseline_ratio)), j});
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < candidates.size() && k < o.neighbours; ++k)
    out.push_back(candidates[k].second);
  return out;
}

std::optional<StereoRange> StereoRangeOf(std::vector<double> z) {
  if (z.size() < kMinStereoPoints) return std::nullopt;
  std::sort(z.begin(), z.end());
  return StereoRange{kStereoNearMargin * z[z.size() * 2 / 100],
                     kStereoFarMargin * z[z.size() * 98 / 100],
                     z[z.size() / 2]};
}

}  // namespace pano4d
