#include "src/geometry/depth_alignment.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <ceres/ceres.h>
#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/median.h"
#include "src/core/option_checks.h"

namespace pano4d {
namespace {

// The relative residual of one sample under each model (DepthModel): (s d
// + b - z) / z, z (s d + b) - 1 (disparity), s d / z - 1 (scale; shift
// held at 0).
struct RelativeResidual {
  RelativeResidual(DepthModel model, double d, double z)
      : model(model), d(d), z(z) {}
  template <typename T>
  bool operator()(const T* scale, const T* shift, T* residual) const {
    switch (model) {
      case DepthModel::kAffineDisparity:
        residual[0] = z * (scale[0] * d + shift[0]) - 1.0;
        break;
      case DepthModel::kScale:
        residual[0] = scale[0] * d / z - 1.0;
        break;
      default:
        residual[0] = (scale[0] * d + shift[0] - z) / z;
    }
    return true;
  }
  DepthModel model;
  double d, z;
};

// Depth values under the samples must spread by at least this fraction of
// their mean for the scale to be determined.
constexpr double kMinDepthSpread = 1e-6;

}  // namespace

void DepthAlignmentOptions::Check() const {
  CheckPositive(robust_scale, "depth alignment", "robust_scale");
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
  return AlignDepthModel(depth, samples, DepthModel::kAffineDepth, options);
}

namespace {

// The map's value under each usable sample (finite, inside, positive depth
// unless the map is a disparity) and the sample's depth.
void SamplePairs(const cv::Mat& map, const std::vector<DepthSample>& samples,
                 bool disparity, std::vector<double>* ds,
                 std::vector<double>* zs) {
  for (const DepthSample& s : samples) {
    if (!s.pixel.allFinite() || !(s.z > 0) || !std::isfinite(s.z)) continue;
    const int u = static_cast<int>(std::floor(s.pixel.x()));
    const int v = static_cast<int>(std::floor(s.pixel.y()));
    if (u < 0 || v < 0 || u >= map.cols || v >= map.rows) continue;
    const float d = map.at<float>(v, u);
    if (!std::isfinite(d) || (!disparity && !(d > 0))) continue;
    ds->push_back(d);
    zs->push_back(s.z);
  }
}

// The start of the robust fit: the plain least-squares fit of the same
// residuals (linear in scale and shift for every model); for an affine
// depth the unweighted line z = s d + b, as pano4d has always started.
void LeastSquaresStart(const Eigen::VectorXd& d, const Eigen::VectorXd& z,
                       DepthModel model, double* scale, double* shift) {
  Eigen::MatrixXd design(d.size(), model == DepthModel::kScale ? 1 : 2);
  Eigen::VectorXd target(d.size());
  for (Eigen::Index i = 0; i < d.size(); ++i) {
    switch (model) {
      case DepthModel::kAffineDisparity:
        design.row(i) << z[i] * d[i], z[i];
        target[i] = 1.0;
        break;
      case DepthModel::kScale:
        design(i, 0) = d[i] / z[i];
        target[i] = 1.0;
        break;
      default:  // replaced below
        design.row(i) << d[i] / z[i], 1.0 / z[i];
        target[i] = 1.0;
    }
  }
  const Eigen::VectorXd start = design.colPivHouseholderQr().solve(target);
  *scale = start[0];
  *shift = model == DepthModel::kScale ? 0.0 : start[1];
  if (model == DepthModel::kAffineDepth) {
    const double d_mean = d.mean(), z_mean = z.mean();
    const double d_var = (d.array() - d_mean).square().mean();
    *scale = ((d.array() - d_mean) * (z.array() - z_mean)).mean() / d_var;
    *shift = z_mean - *scale * d_mean;
  }
}

}  // namespace

DepthAlignment AlignDepthModel(const cv::Mat& map,
                               const std::vector<DepthSample>& samples,
                               DepthModel model,
                               const DepthAlignmentOptions& options) {
  options.Check();
  if (map.empty() || map.type() != CV_32FC1)
    throw Error("depth alignment", "depth", "", "expected a CV_32F map");
  std::vector<double> ds, zs;
  SamplePairs(map, samples, model == DepthModel::kAffineDisparity, &ds, &zs);
  DepthAlignment a;
  a.model = model;
  a.samples = static_cast<int>(ds.size());
  if (a.samples < options.min_samples) {
    throw Error("depth alignment", "samples", std::to_string(a.samples),
                "fewer than " + std::to_string(options.min_samples) +
                    " sparse points fall on valid depth");
  }
  const Eigen::Map<const Eigen::VectorXd> d(ds.data(), ds.size());
  const Eigen::Map<const Eigen::VectorXd> z(zs.data(), zs.size());
  const double d_mean = d.mean();
  const double d_var = (d.array() - d_mean).square().mean();
  if (model != DepthModel::kScale &&
      !(std::sqrt(d_var) > kMinDepthSpread * std::abs(d_mean))) {
    throw Error("depth alignment", "depth", std::to_string(d_mean),
                "constant under the sparse points: the scale is undetermined");
  }
  double scale = 0, shift = 0;
  LeastSquaresStart(d, z, model, &scale, &shift);

  ceres::Problem problem;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<RelativeResidual, 1, 1, 1>(
            new RelativeResidual(model, ds[i], zs[i])),
        new ceres::CauchyLoss(options.robust_scale), &scale, &shift);
  }
  if (model == DepthModel::kScale) problem.SetParameterBlockConstant(&shift);
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
    double r = 0;
    RelativeResidual(model, ds[i], zs[i])(&scale, &shift, &r);
    errors.push_back(std::abs(r));
    if (errors.back() <= options.robust_scale) ++a.inliers;
  }
  a.median_relative_error = UpperMedian(std::move(errors));
  return a;
}

cv::Mat ApplyDepthAlignment(const cv::Mat& map, const DepthAlignment& a,
                            double max_depth) {
  cv::Mat z(map.size(), CV_32FC1, cv::Scalar(0));
  for (int y = 0; y < map.rows; ++y) {
    const float* in = map.ptr<float>(y);
    float* out = z.ptr<float>(y);
    for (int x = 0; x < map.cols; ++x) {
      const double d = in[x];
      if (!std::isfinite(d)) continue;
      double depth = 0;
      switch (a.model) {
        case DepthModel::kAffineDisparity: {
          const double inverse = a.scale * d + a.shift;
          depth = inverse > 0 ? 1.0 / inverse : 0.0;
          break;
        }
        case DepthModel::kScale:
          depth = d > 0 ? a.scale * d : 0.0;
          break;
        default:
          depth = d > 0 ? a.scale * d + a.shift : 0.0;
      }
      if (depth > 0 && depth <= max_depth) out[x] = static_cast<float>(depth);
    }
  }
  return z;
}

cv::Mat CorrectDepthLocally(const cv::Mat& depth, const cv::Mat& reference,
                            const cv::Mat& trusted, double sigma) {
  if (depth.size() != reference.size() || depth.size() != trusted.size()) {
    throw Error("local depth correction", "sizes", "",
                "the depth, reference and trusted maps differ in size");
  }
  cv::Mat weight(depth.size(), CV_32F, cv::Scalar(0));
  cv::Mat value(depth.size(), CV_32F, cv::Scalar(0));
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x) {
      const float d = depth.at<float>(y, x), r = reference.at<float>(y, x);
      if (!trusted.at<std::uint8_t>(y, x) || !(d > 0) || !(r > 0)) continue;
      weight.at<float>(y, x) = 1.0f;
      value.at<float>(y, x) = static_cast<float>(std::clamp(
          std::log(double(r) / d), -kMaxLocalCorrection, kMaxLocalCorrection));
    }
  }
  cv::GaussianBlur(weight, weight, cv::Size(), sigma);
  cv::GaussianBlur(value, value, cv::Size(), sigma);
  cv::Mat out = depth.clone();
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x) {
      float& d = out.at<float>(y, x);
      if (!(d > 0)) continue;
      const float w = std::max(weight.at<float>(y, x),
                               static_cast<float>(kMinLocalSupport));
      d *= std::exp(value.at<float>(y, x) / w);
    }
  }
  return out;
}

MovingDepthPair CompareMovingDepth(const cv::Mat& depth_a,
                                   const cv::Mat& moving_a,
                                   const cv::Mat& depth_b,
                                   const cv::Mat& moving_b,
                                   const cv::Mat& flow_ab, int step) {
  if (depth_a.size() != moving_a.size() || depth_a.size() != flow_ab.size() ||
      depth_b.size() != moving_b.size() || flow_ab.type() != CV_32FC2 ||
      step < 1) {
    throw Error("moving depth comparison", "sizes", "",
                "depth, masks and flow must share their frame's size");
  }
  const int w = depth_a.cols, h = depth_a.rows;
  // Where a's moving pixel (x, y) lands in b, when it lands on a moving
  // pixel of b with depth.
  auto land = [&](int x, int y, cv::Point2f* to, float* z_b) {
    if (!moving_a.at<std::uint8_t>(y, x) || !(depth_a.at<float>(y, x) > 0))
      return false;
    const cv::Vec2f f = flow_ab.at<cv::Vec2f>(y, x);
    *to = cv::Point2f(x + f[0], y + f[1]);
    const int bx = static_cast<int>(std::lround(to->x));
    const int by = static_cast<int>(std::lround(to->y));
    if (bx < 0 || by < 0 || bx >= depth_b.cols || by >= depth_b.rows)
      return false;
    *z_b = depth_b.at<float>(by, bx);
    return moving_b.at<std::uint8_t>(by, bx) && *z_b > 0;
  };
  std::vector<double> ratios, stretches;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      cv::Point2f p;
      float z_b = 0;
      if (!land(x, y, &p, &z_b)) continue;
      ratios.push_back(std::log(z_b / depth_a.at<float>(y, x)));
      for (const cv::Point d : {cv::Point(step, 0), cv::Point(0, step)}) {
        cv::Point2f q;
        float unused = 0;
        if (x + d.x >= w || y + d.y >= h ||
            !land(x + d.x, y + d.y, &q, &unused))
          continue;
        const double length = cv::norm(q - p);
        if (length > 0) stretches.push_back(std::log(length / step));
      }
    }
  }
  MovingDepthPair pair;
  pair.matches = static_cast<int>(ratios.size());
  if (!ratios.empty()) pair.log_depth_ratio = UpperMedian(std::move(ratios));
  if (!stretches.empty()) pair.log_stretch = UpperMedian(std::move(stretches));
  return pair;
}

std::vector<double> ConsistentMovingDepthScales(
    const std::vector<MovingDepthPair>& pairs) {
  const int n = static_cast<int>(pairs.size()) + 1;
  // Normal equations of the chain, the anchor and the mean: small and
  // dense (one row a frame).
  Eigen::MatrixXd a = Eigen::MatrixXd::Identity(n, n) * kScaleAnchorWeight;
  Eigen::VectorXd b = Eigen::VectorXd::Zero(n);
  for (int t = 0; t + 1 < n; ++t) {
    const MovingDepthPair& p = pairs[t];
    if (p.matches < kMinMovingMatches) continue;
    const double target = -p.log_stretch - p.log_depth_ratio;  // c_t+1 - c_t
    a(t, t) += 1;
    a(t + 1, t + 1) += 1;
    a(t, t + 1) -= 1;
    a(t + 1, t) -= 1;
    b(t) -= target;
    b(t + 1) += target;
  }
  a += Eigen::MatrixXd::Ones(n, n);  // (sum c)^2: mean zero
  const Eigen::VectorXd c = a.ldlt().solve(b);
  std::vector<double> out(n);
  for (int t = 0; t < n; ++t) {
    out[t] = std::clamp(std::isfinite(c(t)) ? c(t) : 0.0,
                        -kMaxMovingScaleCorrection, kMaxMovingScaleCorrection);
  }
  return out;
}

}  // namespace pano4d
