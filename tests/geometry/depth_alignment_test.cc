#include "src/geometry/depth_alignment.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

// A depth map d = (z - b) / s of a tilted plane, sampled at random pixels.
struct Scene {
  cv::Mat depth;
  std::vector<DepthSample> samples;
};
Scene MakeScene(double scale, double shift, double outlier_fraction,
                unsigned seed) {
  Scene s;
  s.depth.create(60, 80, CV_32F);
  auto true_z = [](int u, int v) { return 2.0 + 0.03 * u + 0.02 * v; };
  for (int v = 0; v < 60; ++v)
    for (int u = 0; u < 80; ++u)
      s.depth.at<float>(v, u) =
          static_cast<float>((true_z(u, v) - shift) / scale);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pu(0, 80), pv(0, 60), unit(0, 1);
  std::normal_distribution<double> noise(0, 0.005);
  for (int i = 0; i < 300; ++i) {
    DepthSample d;
    d.pixel = {pu(rng), pv(rng)};
    const int u = static_cast<int>(d.pixel.x()),
              v = static_cast<int>(d.pixel.y());
    d.z = true_z(u, v) * (1 + noise(rng));
    if (unit(rng) < outlier_fraction) d.z *= 0.3 + 2 * unit(rng);  // movers
    s.samples.push_back(d);
  }
  return s;
}

TEST(DepthAlignmentTest, RecoversScaleAndShiftDespiteOutliers) {
  const Scene s = MakeScene(2.5, 0.3, 0.25, 1);
  const DepthAlignment a = AlignDepth(s.depth, s.samples);
  EXPECT_NEAR(a.scale, 2.5, 0.025);
  EXPECT_NEAR(a.shift, 0.3, 0.03);
  EXPECT_EQ(a.samples, 300);
  EXPECT_GT(a.inliers, 200);
  EXPECT_LT(a.median_relative_error, 0.01);
}

TEST(DepthAlignmentTest, PlainLeastSquaresWouldBeFarOff) {
  // The same data fitted without the robust loss: a check that the outliers
  // matter, so the test above shows the loss doing its job.
  const Scene s = MakeScene(2.5, 0.3, 0.25, 1);
  const DepthAlignment robust = AlignDepth(s.depth, s.samples);
  const DepthAlignment plain =
      AlignDepth(s.depth, s.samples, {.robust_scale = 1e6});
  EXPECT_GT(std::abs(plain.scale - 2.5), 5 * std::abs(robust.scale - 2.5));
}

TEST(DepthAlignmentTest, InvalidDepthAndPixelsAreSkipped) {
  Scene s = MakeScene(1.0, 0.0, 0.0, 2);
  s.depth(cv::Rect(0, 0, 40, 60)).setTo(0.0f);  // left half: no depth
  s.samples.push_back({{-5, 3}, 2.0});          // outside the map
  s.samples.push_back({{5, 3}, std::nan("")});  // no SfM depth
  const DepthAlignment a = AlignDepth(s.depth, s.samples);
  EXPECT_LT(a.samples, 200);
  EXPECT_NEAR(a.scale, 1.0, 0.01);
}

TEST(DepthAlignmentTest, DegenerateInputsAreErrors) {
  Scene s = MakeScene(1.0, 0.0, 0.0, 3);
  s.samples.resize(5);
  EXPECT_THROW(AlignDepth(s.depth, s.samples), Error);  // too few
  s = MakeScene(1.0, 0.0, 0.0, 3);
  s.depth.setTo(3.0f);
  EXPECT_THROW(AlignDepth(s.depth, s.samples), Error);  // constant depth
  EXPECT_THROW(AlignDepth(cv::Mat(), s.samples), Error);
  EXPECT_THROW(AlignDepth(s.depth, s.samples, {.robust_scale = 0}), Error);
}

// A disparity map d = (1 / z - b) / s of the same plane, as a monocular
// network gives it (an unknown affine in inverse depth), with movers.
TEST(DepthAlignmentTest, DisparityIsAlignedInInverseDepth) {
  Scene s = MakeScene(1.0, 0.0, 0.2, 4);
  const double scale = 0.002, shift = -0.05;
  cv::Mat disparity(s.depth.size(), CV_32F);
  for (int v = 0; v < 60; ++v)
    for (int u = 0; u < 80; ++u)
      disparity.at<float>(v, u) =
          static_cast<float>((1.0 / s.depth.at<float>(v, u) - shift) / scale);
  const DepthAlignment a =
      AlignDepthModel(disparity, s.samples, DepthModel::kAffineDisparity);
  EXPECT_NEAR(a.scale, scale, 0.01 * scale);
  // Within 1% of the inverse depths (0.17 to 0.5) the plane spans.
  EXPECT_NEAR(a.shift, shift, 0.003);
  EXPECT_LT(a.median_relative_error, 0.01);
  // An affine fit in depth cannot follow 1/z: its error is far larger.
  const DepthAlignment wrong =
      AlignDepthModel(disparity, s.samples, DepthModel::kAffineDepth);
  EXPECT_GT(wrong.median_relative_error, 3 * a.median_relative_error);

  const cv::Mat z = ApplyDepthAlignment(disparity, a, 100.0);
  EXPECT_NEAR(z.at<float>(30, 40), s.depth.at<float>(30, 40),
              0.01 * s.depth.at<float>(30, 40));
  // Beyond max_depth, and where the inverse depth is not positive: none.
  EXPECT_EQ(ApplyDepthAlignment(disparity, a, 1.0).at<float>(30, 40), 0.0f);
  cv::Mat far = disparity.clone();
  far.at<float>(0, 0) = static_cast<float>(-shift / scale - 10);
  EXPECT_EQ(ApplyDepthAlignment(far, a, 100.0).at<float>(0, 0), 0.0f);
}

TEST(DepthAlignmentTest, MetricDepthIsAlignedByAScaleAlone) {
  const Scene s = MakeScene(0.5, 0.0, 0.2, 5);
  const DepthAlignment a =
      AlignDepthModel(s.depth, s.samples, DepthModel::kScale);
  EXPECT_NEAR(a.scale, 0.5, 0.005);
  EXPECT_EQ(a.shift, 0.0);
}

TEST(DepthAlignmentTest, LocalCorrectionFollowsTheReferenceAroundAHole) {
  // Learned depth 10% too far on the left half, right on the right half;
  // the reference (stereo) has a hole in the middle of the left half.
  cv::Mat learned(60, 80, CV_32F), reference(60, 80, CV_32F);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) {
      reference.at<float>(y, x) = 5.0f;
      learned.at<float>(y, x) = x < 40 ? 5.5f : 5.0f;
    }
  cv::Mat trusted(60, 80, CV_8UC1, cv::Scalar(255));
  trusted(cv::Rect(10, 20, 15, 20)).setTo(0);  // the moving object
  const cv::Mat fixed = CorrectDepthLocally(learned, reference, trusted, 6.0);
  EXPECT_NEAR(fixed.at<float>(30, 17), 5.0f, 0.05f);  // inside the hole
  EXPECT_NEAR(fixed.at<float>(30, 70), 5.0f, 0.01f);
  // Nothing trusted: the learned depth as it was.
  const cv::Mat none = CorrectDepthLocally(
      learned, reference, cv::Mat(60, 80, CV_8UC1, cv::Scalar(0)), 6.0);
  EXPECT_EQ(none.at<float>(30, 17), 5.5f);
  EXPECT_THROW(CorrectDepthLocally(learned, reference(cv::Rect(0, 0, 10, 10)),
                                   trusted, 6.0),
               Error);
}

// A square moving right at a constant depth of 4, seen in three frames; the
// learned depth of the middle frame puts it 30% too far. The flow does not
// stretch the square, so the comparison sees the jump and the corrections
// undo it (up to the mean, which they keep).
TEST(DepthAlignmentTest, MovingDepthIsMadeConsistentAlongTheFlow) {
  const int w = 80, h = 60;
  std::vector<cv::Mat> depth, moving;
  for (int t = 0; t < 3; ++t) {
    cv::Mat z(h, w, CV_32F, cv::Scalar(10)), m(h, w, CV_8UC1, cv::Scalar(0));
    const cv::Rect square(10 + 5 * t, 15, 30, 30);
    z(square).setTo(t == 1 ? 4.0f * 1.3f : 4.0f);
    m(square).setTo(255);
    depth.push_back(z);
    moving.push_back(m);
  }
  const cv::Mat flow(h, w, CV_32FC2, cv::Scalar(5, 0));
  std::vector<MovingDepthPair> pairs;
  for (int t = 0; t < 2; ++t) {
    pairs.push_back(CompareMovingDepth(depth[t], moving[t], depth[t + 1],
                                       moving[t + 1], flow, 2));
  }
  EXPECT_GT(pairs[0].matches, 800);
  EXPECT_NEAR(pairs[0].log_depth_ratio, std::log(1.3), 1e-6);
  EXPECT_NEAR(pairs[1].log_depth_ratio, -std::log(1.3), 1e-6);
  EXPECT_NEAR(pairs[0].log_stretch, 0.0, 1e-6);
  const std::vector<double> c = ConsistentMovingDepthScales(pairs);
  ASSERT_EQ(c.size(), 3u);
  // The middle frame comes down by 1.3 relative to its neighbours.
  EXPECT_NEAR(c[1] - c[0], -std::log(1.3), 1e-3);
  EXPECT_NEAR(c[2] - c[1], std::log(1.3), 1e-3);
  EXPECT_NEAR(c[0] + c[1] + c[2], 0.0, 1e-6);

  // The square grows by 10% (comes closer) with the depth unchanged: the
  // depth of the later frame must come down by 10%.
  const cv::Mat grow = [&] {
    cv::Mat f(h, w, CV_32FC2);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        f.at<cv::Vec2f>(y, x) = cv::Vec2f(0.1f * (x - 25), 0.1f * (y - 30));
    return f;
  }();
  cv::Mat big(h, w, CV_8UC1, cv::Scalar(0));
  big(cv::Rect(8, 13, 34, 34)).setTo(255);
  cv::Mat z_big(h, w, CV_32F, cv::Scalar(4));
  const MovingDepthPair closer =
      CompareMovingDepth(depth[0], moving[0], z_big, big, grow, 4);
  EXPECT_NEAR(closer.log_stretch, std::log(1.1), 1e-3);
  const std::vector<double> d = ConsistentMovingDepthScales({closer});
  EXPECT_NEAR(d[1] - d[0], -std::log(1.1), 1e-3);

  // A pair with too few matches links nothing: no correction.
  MovingDepthPair few = pairs[0];
  few.matches = kMinMovingMatches - 1;
  for (const double v : ConsistentMovingDepthScales({few})) EXPECT_EQ(v, 0.0);
  EXPECT_THROW(CompareMovingDepth(depth[0], moving[0](cv::Rect(0, 0, 5, 5)),
                                  depth[1], moving[1], flow, 2),
               Error);
}

}  // namespace
}  // namespace pano4d
