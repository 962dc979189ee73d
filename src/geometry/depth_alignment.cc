#include "src/geometry/depth_alignment.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <ceres/ceres.h>

#include "src/core/error.h"
#include "src/core/median.h"

namespace pano4d {
namespace {

// (s d + b - z) / z: relative, so near and far points weigh alike.
struct RelativeDepthResidual {
  RelativeDepthResidual(double d, double z) : d(d), z(z) {}
  template <typename T>
  bool operator()(const T* scale, const T* shift, T* residual) const {
    residual[0] = (scale[0] * d + shift[0] - z) / z;
    return true;
  }
  double d, z;
};

// Depth values under the samples must spread by at least this fraction of
// their mean for the scale to be determined.
constexpr double kMinDepthSpread = 1e-6;

}  // namespace

void DepthAlignmentOptions::Check() const {
  if (!(robust_scale > 0))
    throw Error("depth alignment", "robust_scale", std::to_string(robust_scale),
                "must be > 0");
  if (min_samples < 2)
    throw Error("depth alignment", "min_samples", std::to_string(min_samples),
                "must be >= 2");
  if (max_iterations < 1)
    throw Error("depth alignment", "max_iterations",
                std::to_string(max_iterations), "must be >= 1");
}

DepthAlignment AlignDepth(const cv::Mat& depth,
                          const std::vector<DepthSample>& samples,
                          const DepthAlignmentOptions& options) {
  options.Check();
  if (depth.empty() || depth.type() != CV_32FC1)
    throw Error("depth alignment", "depth", "", "expected a CV_32F map");
  std::vector<double> ds, zs;
  for (const DepthSample& s : samples) {
    if (!s.pixel.allFinite() || !(s.z > 0) || !std::isfinite(s.z)) continue;
    const int u = static_cast<int>(std::floor(s.pixel.x()));
    const int v = static_cast<int>(std::floor(s.pixel.y()));
    if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows) continue;
    const float d = depth.at<float>(v, u);
    if (!(d > 0) || !std::isfinite(d)) continue;
    ds.push_back(d);
    zs.push_back(s.z);
  }
  DepthAlignment a;
  a.samples = static_cast<int>(ds.size());
  if (a.samples < options.min_samples) {
    throw Error("depth alignment", "samples", std::to_string(a.samples),
                "fewer than " + std::to_string(options.min_samples) +
                    " sparse points fall on valid depth");
  }
  // Start: the least-squares line z = s d + b.
  const Eigen::Map<const Eigen::VectorXd> d(ds.data(), ds.size());
  const Eigen::Map<const Eigen::VectorXd> z(zs.data(), zs.size());
  const double d_mean = d.mean(), z_mean = z.mean();
  const double d_var = (d.array() - d_mean).square().mean();
  if (!(std::sqrt(d_var) > kMinDepthSpread * std::abs(d_mean))) {
    throw Error("depth alignment", "depth", std::to_string(d_mean),
                "constant under the sparse points: the scale is undetermined");
  }
  double scale = ((d.array() - d_mean) * (z.array() - z_mean)).mean() / d_var;
  double shift = z_mean - scale * d_mean;

  ceres::Problem problem;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<RelativeDepthResidual, 1, 1, 1>(
            new RelativeDepthResidual(ds[i], zs[i])),
        new ceres::CauchyLoss(options.robust_scale), &scale, &shift);
  }
  ceres::Solver::Options solver;
  solver.max_num_iterations = options.max_iterations;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!std::isfinite(scale) || !std::isfinite(shift)) {
    throw Error("depth alignment", "solution", "",
                "not finite: " + summary.BriefReport());
  }
  a.scale = scale;
  a.shift = shift;
  std::vector<double> errors;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    errors.push_back(std::abs((scale * ds[i] + shift - zs[i]) / zs[i]));
    if (errors.back() <= options.robust_scale) ++a.inliers;
  }
  a.median_relative_error = UpperMedian(std::move(errors));
  return a;
}

}  // namespace pano4d
