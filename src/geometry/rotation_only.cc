#include "src/geometry/rotation_only.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>

#include "src/core/error.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

// The focal lengths searched, per larger image side: from a 127-degree to
// a 14-degree field of view, wider than phones and most lenses give.
constexpr double kMinFocalPerSide = 0.25, kMaxFocalPerSide = 4.0;
constexpr int kFocalSteps = 400;  // log-spaced: 0.7% apart
// Huber scale of the bundle adjustment (pixels): matches further off than
// this are outliers RANSAC let through, and count linearly.
constexpr double kHuberPixels = 1.0;

struct Pair {
  const FrameMatches* matches = nullptr;
  Eigen::Matrix3d h;         // x_j ~ h x_i
  std::vector<int> inliers;  // indices into matches->xi
};

Eigen::Matrix3d Intrinsics(double f, double cx, double cy) {
  Eigen::Matrix3d k;
  k << f, 0, cx, 0, f, cy, 0, 0, 1;
  return k;
}

Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  if ((u * svd.matrixV().transpose()).determinant() < 0) u.col(2) *= -1;
  return u * svd.matrixV().transpose();
}

// How far the homographies are from rotations at focal length f: the sum
// over pairs of |M M^T - I|^2, M = K^-1 H K scaled to determinant 1.
double RotationMisfit(const std::vector<Pair>& pairs, double f, double cx,
                      double cy) {
  const Eigen::Matrix3d k = Intrinsics(f, cx, cy);
  const Eigen::Matrix3d k_inv = k.inverse();
  double sum = 0;
  for (const Pair& p : pairs) {
    Eigen::Matrix3d m = k_inv * p.h * k;
    const double det = m.determinant();
    if (!(std::abs(det) > 0)) return std::numeric_limits<double>::infinity();
    m /= std::cbrt(det);
    sum += (m * m.transpose() - Eigen::Matrix3d::Identity()).squaredNorm();
  }
  return sum;
}

// A match of frame i carried to frame j by the two rotations, against
// where frame j saw it (pixels).
struct TransferResidual {
  Eigen::Vector2d xi, xj;
  double cx, cy;
  template <typename T>
  bool operator()(const T* f, const T* rotation_i, const T* rotation_j,
                  T* residual) const {
    const T ray[3] = {(T(xi.x()) - T(cx)) / f[0], (T(xi.y()) - T(cy)) / f[0],
                      T(1)};
    const T back[3] = {-rotation_i[0], -rotation_i[1], -rotation_i[2]};
    T world[3], camera[3];
    ceres::AngleAxisRotatePoint(back, ray, world);
    ceres::AngleAxisRotatePoint(rotation_j, world, camera);
    residual[0] = f[0] * camera[0] / camera[2] + T(cx) - T(xj.x());
    residual[1] = f[0] * camera[1] / camera[2] + T(cy) - T(xj.y());
    return true;
  }
};

std::vector<cv::Point2f> ToCv(const std::vector<Eigen::Vector2d>& points) {
  std::vector<cv::Point2f> out;
  out.reserve(points.size());
  for (const Eigen::Vector2d& p : points)
    out.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  return out;
}

// A homography per pair with at least min_inliers RANSAC inliers.
std::vector<Pair> PairHomographies(int frames,
                                   const std::vector<FrameMatches>& given,
                                   const RotationOnlyOptions& options) {
  std::vector<Pair> pairs;
  for (const FrameMatches& m : given) {
    if (m.xi.size() != m.xj.size()) {
      throw Error("rotation-only model", "matches",
                  StringPrintf("%zu against %zu", m.xi.size(), m.xj.size()),
                  "each match needs a point in both frames");
    }
    if (static_cast<int>(m.xi.size()) < options.min_inliers || m.i == m.j ||
        m.i < 0 || m.j < 0 || m.i >= frames || m.j >= frames)
      continue;
    std::vector<unsigned char> mask;
    const cv::Mat h = cv::findHomography(ToCv(m.xi), ToCv(m.xj), cv::RANSAC,
                                         options.ransac_pixels, mask);
    if (h.empty()) continue;
    Pair p;
    p.matches = &m;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) p.h(r, c) = h.at<double>(r, c);
    for (std::size_t k = 0; k < mask.size(); ++k)
      if (mask[k]) p.inliers.push_back(static_cast<int>(k));
    if (static_cast<int>(p.inliers.size()) >= options.min_inliers)
      pairs.push_back(std::move(p));
  }
  if (pairs.empty()) {
    throw Error::In("rotation-only model",
                    StringPrintf("no pair of frames has %d matches a "
                                 "homography explains",
                                 options.min_inliers));
  }
  return pairs;
}

// A still camera: every homography moves the image corners by less than
// kStillPixels. Its focal length is unobservable; COLMAP's prior for an
// unknown focal length stands in. nullopt when the camera turns.
std::optional<RotationOnlyEstimate> StillCamera(const std::vector<Pair>& pairs,
                                                int frames, int width,
                                                int height) {
  constexpr double kStillPixels = 1.0, kPriorFocalPerSide = 1.2;
  double largest_move = 0;
  for (const Pair& p : pairs) {
    for (const Eigen::Vector2d& corner :
         {Eigen::Vector2d(0, 0), Eigen::Vector2d(width, 0),
          Eigen::Vector2d(0, height), Eigen::Vector2d(width, height)}) {
      const Eigen::Vector2d moved = (p.h * corner.homogeneous()).hnormalized();
      largest_move = std::max(largest_move, (moved - corner).norm());
    }
  }
  if (largest_move >= kStillPixels) return std::nullopt;
  RotationOnlyEstimate still;
  still.width = width;
  still.height = height;
  still.focal = kPriorFocalPerSide * std::max(width, height);
  still.cam_from_world.assign(frames, std::nullopt);
  double sum = 0;
  std::int64_t count = 0;
  for (const Pair& p : pairs) {
    still.cam_from_world[p.matches->i] = Eigen::Matrix3d::Identity();
    still.cam_from_world[p.matches->j] = Eigen::Matrix3d::Identity();
    ++still.pairs;
    for (const int idx : p.inliers) {
      sum += (p.matches->xi[idx] - p.matches->xj[idx]).squaredNorm();
      ++count;
    }
  }
  still.rms_pixels = count > 0 ? std::sqrt(sum / count) : 0.0;
  return still;
}

// The focal length whose K makes the homographies most like rotations: a
// log-spaced search, then a golden-section refinement.
double SearchFocal(const std::vector<Pair>& pairs, int width, int height) {
  const double cx = width / 2.0, cy = height / 2.0;
  const double side = std::max(width, height);
  const double lo = std::log(kMinFocalPerSide * side);
  const double hi = std::log(kMaxFocalPerSide * side);
  const double step = (hi - lo) / kFocalSteps;
  int best = 0;
  double best_misfit = std::numeric_limits<double>::infinity();
  for (int s = 0; s <= kFocalSteps; ++s) {
    const double misfit =
        RotationMisfit(pairs, std::exp(lo + s * step), cx, cy);
    if (misfit < best_misfit) best_misfit = misfit, best = s;
  }
  if (best == 0 || best == kFocalSteps) {
    throw Error("rotation-only model", "focal length",
                StringPrintf("%.1f px", std::exp(lo + best * step)),
                StringPrintf("the homographies fit no focal length in "
                             "%.2f-%.1f x the image side: the camera does "
                             "not only turn",
                             kMinFocalPerSide, kMaxFocalPerSide));
  }
  double a = lo + (best - 1) * step, b = lo + (best + 1) * step;
  const double golden = (std::sqrt(5.0) - 1) / 2;
  for (int it = 0; it < 40; ++it) {
    const double c = b - golden * (b - a), d = a + golden * (b - a);
    if (RotationMisfit(pairs, std::exp(c), cx, cy) <
        RotationMisfit(pairs, std::exp(d), cx, cy))
      b = d;
    else
      a = c;
  }
  return std::exp((a + b) / 2);
}

// Rotations along a spanning tree of the strongest pairs (sorted so), from
// the first frame any pair holds, whose index is returned: R_j R_i^T =
// K^-1 H_ij K.
int ChainRotations(std::vector<Pair>* pairs, double focal, double cx, double cy,
                   RotationOnlyEstimate* out) {
  std::sort(pairs->begin(), pairs->end(), [](const Pair& x, const Pair& y) {
    return x.inliers.size() > y.inliers.size();
  });
  const int frames = static_cast<int>(out->cam_from_world.size());
  int reference = frames;
  for (const Pair& p : *pairs)
    reference = std::min({reference, p.matches->i, p.matches->j});
  out->cam_from_world[reference] = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d k = Intrinsics(focal, cx, cy);
  for (bool grew = true; grew;) {
    grew = false;
    for (const Pair& p : *pairs) {
      auto& ri = out->cam_from_world[p.matches->i];
      auto& rj = out->cam_from_world[p.matches->j];
      if (ri.has_value() == rj.has_value()) continue;
      const Eigen::Matrix3d rij = NearestRotation(k.inverse() * p.h * k);
      if (ri)
        rj = rij * *ri;
      else
        ri = rij.transpose() * *rj;
      grew = true;
      break;  // the strongest pair first, again
    }
  }
  return reference;
}

// Bundle adjustment of the rotations and the focal length (the reference
// frame's rotation held), on up to max_matches_per_pair inliers a pair.
void AdjustRotations(const std::vector<Pair>& pairs, int reference, double cx,
                     double cy, const RotationOnlyOptions& options,
                     RotationOnlyEstimate* out, double* focal) {
  const int frames = static_cast<int>(out->cam_from_world.size());
  std::vector<std::array<double, 3>> angle_axis(frames);
  for (int f = 0; f < frames; ++f) {
    if (!out->cam_from_world[f]) continue;
    const Eigen::Matrix3d& r = *out->cam_from_world[f];
    ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(r.data()),
                                     angle_axis[f].data());
  }
  ceres::Problem problem;
  for (const Pair& p : pairs) {
    const FrameMatches& m = *p.matches;
    if (!out->cam_from_world[m.i] || !out->cam_from_world[m.j]) continue;
    ++out->pairs;
    const int n = static_cast<int>(p.inliers.size());
    const int keep = std::min(n, options.max_matches_per_pair);
    for (int s = 0; s < keep; ++s) {
      const int idx = p.inliers[static_cast<std::size_t>(s) * n / keep];
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<TransferResidual, 2, 1, 3, 3>(
              new TransferResidual{m.xi[idx], m.xj[idx], cx, cy}),
          new ceres::HuberLoss(kHuberPixels), focal, angle_axis[m.i].data(),
          angle_axis[m.j].data());
    }
  }
  problem.SetParameterBlockConstant(angle_axis[reference].data());
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = 50;
  solver.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable() || !std::isfinite(*focal) || *focal <= 0) {
    throw Error("rotation-only model", "bundle adjustment", "",
                summary.BriefReport());
  }
  for (int f = 0; f < frames; ++f) {
    if (!out->cam_from_world[f]) continue;
    Eigen::Matrix3d r;
    ceres::AngleAxisToRotationMatrix(angle_axis[f].data(),
                                     ceres::ColumnMajorAdapter3x3(r.data()));
    out->cam_from_world[f] = r;
  }
}

// The transfer error over every inlier of the posed pairs (pixels, RMS).
double TransferRms(const std::vector<Pair>& pairs,
                   const RotationOnlyEstimate& out, double cx, double cy) {
  double sum = 0;
  std::int64_t count = 0;
  const Eigen::Matrix3d kf = Intrinsics(out.focal, cx, cy);
  for (const Pair& p : pairs) {
    const FrameMatches& m = *p.matches;
    if (!out.cam_from_world[m.i] || !out.cam_from_world[m.j]) continue;
    const Eigen::Matrix3d h = kf * *out.cam_from_world[m.j] *
                              out.cam_from_world[m.i]->transpose() *
                              kf.inverse();
    for (const int idx : p.inliers) {
      const Eigen::Vector3d x = h * m.xi[idx].homogeneous();
      sum += (x.hnormalized() - m.xj[idx]).squaredNorm();
      ++count;
    }
  }
  return count > 0 ? std::sqrt(sum / count) : 0.0;
}

}  // namespace

int RotationOnlyEstimate::Posed() const {
  return static_cast<int>(
      std::count_if(cam_from_world.begin(), cam_from_world.end(),
                    [](const auto& r) { return r.has_value(); }));
}

RotationOnlyEstimate EstimateRotationOnly(
    int frames, int width, int height, const std::vector<FrameMatches>& given,
    const RotationOnlyOptions& options) {
  const double cx = width / 2.0, cy = height / 2.0;
  std::vector<Pair> pairs = PairHomographies(frames, given, options);
  if (std::optional<RotationOnlyEstimate> still =
          StillCamera(pairs, frames, width, height))
    return *still;
  double focal = SearchFocal(pairs, width, height);
  RotationOnlyEstimate out;
  out.width = width;
  out.height = height;
  out.cam_from_world.assign(frames, std::nullopt);
  const int reference = ChainRotations(&pairs, focal, cx, cy, &out);
  AdjustRotations(pairs, reference, cx, cy, options, &out, &focal);
  out.focal = focal;
  out.rms_pixels = TransferRms(pairs, out, cx, cy);
  return out;
}

}  // namespace pano4d
