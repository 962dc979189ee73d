#include "src/geometry/stereo.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

// Cost of a pixel that a neighbour does not see under a plane (it warps
// outside that image): worse than any correlation (1 - ZNCC <= 2).
constexpr float kNoCost = 3.0f;
// Added under the square root of ZNCC's denominator: flat windows give 0
// correlation instead of 0 / 0.
constexpr double kVarianceFloor = 1e-8;

cv::Matx33d Intrinsics(const Camera& c) {
  // OpenCV's warps address pixel centres at integers; COLMAP's at +0.5.
  return {c.focal_x(), 0,           c.principal_x() - 0.5,
          0,           c.focal_y(), c.principal_y() - 0.5,
          0,           0,           1};
}

cv::Matx33d Rotation(const Rigid3d& pose) {
  const Eigen::Matrix3d r = pose.rotation.toRotationMatrix();
  return {r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1),
          r(1, 2), r(2, 0), r(2, 1), r(2, 2)};
}

void CheckView(const StereoView& v, const std::string& what) {
  if (v.grey.type() != CV_32F || v.grey.cols != v.camera.camera.width ||
      v.grey.rows != v.camera.camera.height) {
    throw Error("plane sweep", what, SizeText(v.grey.cols, v.grey.rows),
                "expected a CV_32F grey image of its camera's size");
  }
  if (v.camera.camera.HasDistortion()) {
    throw Error("plane sweep", what, std::string(v.camera.camera.info().name),
                "expected a pinhole camera");
  }
}

}  // namespace

void PlaneSweepOptions::Check() const {
  if (planes < 3) {
    throw Error("plane sweep", "planes", std::to_string(planes), "at least 3");
  }
  if (window < 3 || window % 2 == 0) {
    throw Error("plane sweep", "window", std::to_string(window),
                "must be odd and at least 3");
  }
  if (!(min_correlation > -1 && min_correlation < 1)) {
    throw Error("plane sweep", "min_correlation",
                std::to_string(min_correlation), "must be in (-1, 1)");
  }
  if (!(min_texture >= 0)) {
    throw Error("plane sweep", "min_texture", std::to_string(min_texture),
                "must be zero or positive");
  }
}

namespace {

// The reference's local statistics over the window: mean and variance.
struct WindowStats {
  cv::Mat mean, variance;
};

WindowStats ReferenceStats(const cv::Mat& a, const cv::Size& window) {
  WindowStats s;
  cv::Mat aa;
  cv::boxFilter(a, s.mean, CV_32F, window);
  cv::boxFilter(a.mul(a), aa, CV_32F, window);
  s.variance = cv::max(aa - s.mean.mul(s.mean), 0.0);
  return s;
}

// 1 - the windowed normalised cross-correlation of the reference with the
// neighbour warped onto the plane at depth d (the plane-induced homography),
// kNoCost where the neighbour does not see.
cv::Mat PlaneCost(const StereoView& reference, const WindowStats& ref,
                  const StereoView& nb, double d, const cv::Size& window) {
  const cv::Size size = reference.grey.size();
  const cv::Mat& a = reference.grey;
  const cv::Matx33d k_ref_inv = Intrinsics(reference.camera.camera).inv();
  const cv::Matx33d r_ref = Rotation(reference.camera.cam_from_world);
  const Eigen::Vector3d t_ref = reference.camera.cam_from_world.translation;
  const cv::Matx33d r_nb = Rotation(nb.camera.cam_from_world);
  const Eigen::Vector3d t_nb = nb.camera.cam_from_world.translation;
  // nb_from_ref: x_nb = R x_ref + T; on the plane z_ref = d,
  // x_nb = (R + T n^T / d) x_ref with n = (0, 0, 1).
  const cv::Matx33d r = r_nb * r_ref.t();
  const cv::Vec3d t_ref_cv(t_ref.x(), t_ref.y(), t_ref.z());
  const cv::Vec3d t = cv::Vec3d(t_nb.x(), t_nb.y(), t_nb.z()) - r * t_ref_cv;
  cv::Matx33d plane = r;
  for (int i = 0; i < 3; ++i) plane(i, 2) += t[i] / d;
  const cv::Matx33d h = Intrinsics(nb.camera.camera) * plane * k_ref_inv;
  cv::Mat b, seen;
  cv::warpPerspective(nb.grey, b, h, size,
                      cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT, 0);
  cv::warpPerspective(cv::Mat::ones(nb.grey.size(), CV_8U), seen, h, size,
                      cv::INTER_NEAREST | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT, 0);
  cv::Mat mu_b, bb, ab;
  cv::boxFilter(b, mu_b, CV_32F, window);
  cv::boxFilter(b.mul(b), bb, CV_32F, window);
  cv::boxFilter(a.mul(b), ab, CV_32F, window);
  const cv::Mat var_b = cv::max(bb - mu_b.mul(mu_b), 0.0);
  const cv::Mat cov = ab - ref.mean.mul(mu_b);
  cv::Mat denom;
  cv::sqrt(ref.variance.mul(var_b) + kVarianceFloor, denom);
  cv::Mat cost = 1.0 - cov / denom;
  cost.setTo(kNoCost, seen == 0);
  return cost;
}

// Per pixel, the mean of the best `keep` of the neighbours' costs.
cv::Mat BestCostMean(const std::vector<cv::Mat>& per, int keep) {
  const cv::Size size = per.front().size();
  cv::Mat total(size, CV_32F);
  std::vector<float> values(per.size());
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      for (std::size_t j = 0; j < per.size(); ++j)
        values[j] = per[j].at<float>(y, x);
      std::partial_sort(values.begin(), values.begin() + keep, values.end());
      float sum = 0;
      for (int j = 0; j < keep; ++j) sum += values[j];
      total.at<float>(y, x) = sum / keep;
    }
  }
  return total;
}

}  // namespace

cv::Mat PlaneSweepDepth(const StereoView& reference,
                        const std::vector<StereoView>& neighbours, double near,
                        double far, const PlaneSweepOptions& o) {
  o.Check();
  CheckView(reference, "reference");
  for (const StereoView& n : neighbours) CheckView(n, "neighbour");
  if (neighbours.empty()) {
    throw Error("plane sweep", "neighbours", "0", "at least one is needed");
  }
  if (!(near > 0 && far > near && std::isfinite(far))) {
    throw Error("plane sweep", "depth range",
                std::to_string(near) + ".." + std::to_string(far),
                "need 0 < near < far");
  }
  const cv::Size size = reference.grey.size();
  const cv::Size window(o.window, o.window);
  const WindowStats ref = ReferenceStats(reference.grey, window);
  const double inv_near = 1.0 / near, inv_far = 1.0 / far;
  const int planes = o.planes;
  const auto inverse_depth = [&](double k) {
    return inv_far + (inv_near - inv_far) * k / (planes - 1);
  };
  const int keep = std::max(1, static_cast<int>(neighbours.size()) / 2);

  std::vector<cv::Mat> costs(planes);
  cv::parallel_for_(cv::Range(0, planes), [&](const cv::Range& range) {
    std::vector<cv::Mat> per(neighbours.size());
    for (int k = range.start; k < range.end; ++k) {
      const double d = 1.0 / inverse_depth(k);
      for (std::size_t j = 0; j < neighbours.size(); ++j)
        per[j] = PlaneCost(reference, ref, neighbours[j], d, window);
      costs[k] = BestCostMean(per, keep);
    }
  });

  // Per pixel the plane of least cost, refined by a parabola through its
  // neighbours' costs; none where the texture is too weak, the best plane is
  // an end of the range, or the correlation is too low.
  cv::Mat depth(size, CV_32F, cv::Scalar(0));
  const float max_cost = static_cast<float>(1.0 - o.min_correlation);
  const float min_var = static_cast<float>(o.min_texture * o.min_texture);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      if (ref.variance.at<float>(y, x) < min_var) continue;
      int best = 0;
      float best_cost = costs[0].at<float>(y, x);
      for (int k = 1; k < planes; ++k) {
        const float c = costs[k].at<float>(y, x);
        if (c < best_cost) {
          best_cost = c;
          best = k;
        }
      }
      if (best == 0 || best == planes - 1 || best_cost > max_cost) continue;
      const double c0 = costs[best - 1].at<float>(y, x);
      const double c2 = costs[best + 1].at<float>(y, x);
      const double curvature = c0 - 2.0 * best_cost + c2;
      const double offset =
          curvature > 0 ? std::clamp(0.5 * (c0 - c2) / curvature, -0.5, 0.5)
                        : 0.0;
      depth.at<float>(y, x) =
          static_cast<float>(1.0 / inverse_depth(best + offset));
    }
  }
  return depth;
}

}  // namespace pano4d
