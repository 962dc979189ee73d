#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace pano4d {

// A sparse SfM point as one camera sees it: its pixel (COLMAP convention,
// pixel centres at +0.5) and its depth along that camera's optical axis.
struct DepthSample {
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  double z = 0.0;
};

struct DepthAlignmentOptions {
  // Cauchy loss scale on the relative residual (s d + b - z) / z: samples
  // off by much more than this fraction of their depth (moving objects,
  // mismatched points) barely pull the fit.
  double robust_scale = 0.05;
  int min_samples = 10;  // fewer: no reliable fit
  int max_iterations = 50;
  void Check() const;  // throws pano4d::Error naming the field
};

// How a map's values relate to z-depth: the fitted parameters.
enum class DepthModel {
  kAffineDepth,      // z = s d + b: stereo, a tool's depth up to an affine
  kAffineDisparity,  // 1 / z = s d + b: a monocular network's disparity
  kScale,            // z = s d: metric depth in other units
};

struct DepthAlignment {
  DepthModel model = DepthModel::kAffineDepth;
  double scale = 1.0;  // z ~ scale * depth + shift (see DepthModel)
  double shift = 0.0;
  int samples = 0;  // samples with a valid depth under them
  int inliers = 0;  // of those, within robust_scale relative error
  double median_relative_error = 0.0;
};

// The scale and shift that bring a depth map (CV_32F, 0 or non-finite =
// no depth; e.g. from stereo or a monocular network) onto the SfM depths of
// `samples`, by a robust least-squares fit (Ceres, Cauchy loss) started from
// the plain least-squares line. Throws pano4d::Error when fewer than
// min_samples samples fall on valid depth, or when the depth under them is
// (nearly) constant, which leaves the scale undetermined.
DepthAlignment AlignDepth(const cv::Mat& depth,
                          const std::vector<DepthSample>& samples,
                          const DepthAlignmentOptions& options = {});

// The same fit for any DepthModel, with the relative residual of each: for
// disparity z (s d + b) - 1, the relative error in inverse depth, so that
// near and far points weigh alike and the fit stays linear. A disparity
// map may hold 0 and negative values (a network's far background): every
// finite value counts.
DepthAlignment AlignDepthModel(const cv::Mat& map,
                               const std::vector<DepthSample>& samples,
                               DepthModel model,
                               const DepthAlignmentOptions& options = {});

// The z-depth map of `map` under `a`: 0 where the model gives no positive
// depth or a depth beyond max_depth (a disparity near 0 is the far
// background, whose depth an affine fit on nearer points cannot say).
cv::Mat ApplyDepthAlignment(const cv::Mat& map, const DepthAlignment& a,
                            double max_depth);

// `depth` (a learned map already aligned) corrected towards `reference`
// (stereo) by a smooth factor: the log of reference / depth over the pixels
// where `trusted` is set and both have depth, clamped to
// +-kMaxLocalCorrection, spread by a Gaussian of `sigma` pixels normalised
// by the trusted pixels' weight (the weight floored at kMinLocalSupport, so
// that far from any trusted pixel the factor fades to 1). A monocular
// network's disparity is an affine of inverse depth only roughly (MiDaS on
// Balloon1: 5-19% median error after the best affine per frame); its
// errors are smooth, so a moving object takes the correction of the static
// surfaces around it.
inline constexpr double kMaxLocalCorrection = 0.4;  // log: x1.5
inline constexpr double kMinLocalSupport = 0.05;
cv::Mat CorrectDepthLocally(const cv::Mat& depth, const cv::Mat& reference,
                            const cv::Mat& trusted, double sigma);

// Moving pixels of frame a matched by the flow a -> b to moving pixels of
// b with depth in both: the median log ratio of their depths (b over a)
// and the median log ratio by which the flow stretches the moving content
// (distances between a moving pixel and its neighbour `step` pixels right
// or below, in b over in a). A surface that looks s times larger is 1/s
// times as far, so a depth ratio that disagrees with the stretch is depth
// error: a network's disparity aligned per frame can jump by tens of
// percent on a near moving object between neighbouring frames, while the
// flow, a matching of pixels, holds its scale to a few percent.
struct MovingDepthPair {
  double log_depth_ratio = 0;
  double log_stretch = 0;
  int matches = 0;
};
MovingDepthPair CompareMovingDepth(const cv::Mat& depth_a,
                                   const cv::Mat& moving_a,
                                   const cv::Mat& depth_b,
                                   const cv::Mat& moving_b,
                                   const cv::Mat& flow_ab, int step);

// A pair with fewer matches says nothing about its frames' scales.
inline constexpr int kMinMovingMatches = 200;

// Log-scale corrections c_t of the moving pixels' depth in a sequence of
// frames, pairs[t] comparing frame t with t + 1: least squares on
// log_depth_ratio + c_(t+1) - c_t = -log_stretch over the pairs with
// kMinMovingMatches matches, with mean zero (the per-frame alignment's
// scale is right on average) and a weak pull of each c_t to zero
// (kScaleAnchorWeight) so that frames no pair links stay as they are.
// Each c_t is clamped to +-kMaxMovingScaleCorrection.
inline constexpr double kScaleAnchorWeight = 1e-3;
inline constexpr double kMaxMovingScaleCorrection = 0.7;  // log: x2
std::vector<double> ConsistentMovingDepthScales(
    const std::vector<MovingDepthPair>& pairs);

}  // namespace pano4d
