#include "colmap_ext/alignment.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "src/core/error.h"

namespace pano4d {
namespace {

// Points whose spread across their second principal direction is below
// this fraction of the first are treated as collinear: the rotation about
// their common line is then fixed only by noise.
constexpr double kMinSpreadRatio = 1e-6;

Eigen::Matrix3Xd ToMatrix(const std::vector<Eigen::Vector3d>& points,
                          const char* which) {
  Eigen::Matrix3Xd m(3, points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) {
      throw Error("alignment",
                  std::string(which) + "[" + std::to_string(i) + "]", "",
                  "point is not finite");
    }
    m.col(i) = points[i];
  }
  return m;
}

double Median(std::vector<double> v) {
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  if (v.size() % 2 == 1) return v[mid];
  return 0.5 * (v[mid] + *std::max_element(v.begin(), v.begin() + mid));
}

}  // namespace

Sim3d AlignPoints(const std::vector<Eigen::Vector3d>& source,
                  const std::vector<Eigen::Vector3d>& target) {
  if (source.size() != target.size()) {
    throw Error(
        "alignment", "points",
        std::to_string(source.size()) + " vs " + std::to_string(target.size()),
        "source and target counts differ");
  }
  if (source.size() < 3) {
    throw Error("alignment", "points", std::to_string(source.size()),
                "need at least 3 pairs for a similarity");
  }
  const Eigen::Matrix3Xd src = ToMatrix(source, "source");
  const Eigen::Matrix3Xd dst = ToMatrix(target, "target");
  const Eigen::Matrix3Xd centred = src.colwise() - src.rowwise().mean();
  const Eigen::Vector3d spread =
      Eigen::JacobiSVD<Eigen::Matrix3Xd>(centred).singularValues();
  if (!(spread(1) > kMinSpreadRatio * spread(0))) {
    throw Error("alignment", "source points", "",
                "collinear or coincident: the rotation about their line is "
                "undetermined");
  }
  return Sim3d::FromMatrix(Eigen::umeyama(src, dst, /*with_scaling=*/true));
}

TrajectoryErrors CompareTrajectories(const std::vector<Rigid3d>& estimate,
                                     const std::vector<Rigid3d>& reference) {
  std::vector<Eigen::Vector3d> est_centres, ref_centres;
  for (const Rigid3d& pose : estimate)
    est_centres.push_back(CameraCenter(pose));
  for (const Rigid3d& pose : reference)
    ref_centres.push_back(CameraCenter(pose));
  TrajectoryErrors e;
  e.cameras = static_cast<int>(estimate.size());
  e.reference_from_estimate = AlignPoints(est_centres, ref_centres);

  std::vector<double> distances;
  double sum = 0, sum_sq = 0;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    const double d =
        (ref_centres[i] - e.reference_from_estimate * est_centres[i]).norm();
    distances.push_back(d);
    sum += d;
    sum_sq += d * d;
    e.ate_max = std::max(e.ate_max, d);
  }
  e.ate_mean = sum / distances.size();
  e.ate_rmse = std::sqrt(sum_sq / distances.size());
  e.ate_median = Median(distances);

  double t_sq = 0, r_sq = 0;
  for (std::size_t i = 0; i + 1 < estimate.size(); ++i) {
    const Rigid3d est_i = e.reference_from_estimate.TransformPose(estimate[i]);
    const Rigid3d est_j =
        e.reference_from_estimate.TransformPose(estimate[i + 1]);
    // Motion from camera i to camera j, expressed as i_from_j.
    const Rigid3d est_rel = est_i * est_j.Inverse();
    const Rigid3d ref_rel = reference[i] * reference[i + 1].Inverse();
    const Rigid3d error = ref_rel.Inverse() * est_rel;
    t_sq += error.translation.squaredNorm();
    const double angle = Eigen::AngleAxisd(error.rotation).angle();
    r_sq += angle * angle;
  }
  const std::size_t pairs = estimate.size() - 1;
  e.rpe_translation_rmse = std::sqrt(t_sq / pairs);
  e.rpe_rotation_rmse_deg = std::sqrt(r_sq / pairs) * 180.0 / std::numbers::pi;
  return e;
}

double RobustExtent(const std::vector<Eigen::Vector3d>& points) {
  constexpr std::size_t kMinPoints = 10;
  if (points.size() < kMinPoints) return 0.0;
  Eigen::Vector3d low, high;
  std::vector<double> v(points.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (std::size_t i = 0; i < points.size(); ++i) v[i] = points[i](axis);
    std::sort(v.begin(), v.end());
    low(axis) = v[v.size() / 20];
    high(axis) = v[v.size() - 1 - v.size() / 20];
  }
  return (high - low).norm();
}

}  // namespace pano4d
