#include "src/geometry/stereo.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"

namespace pano4d {
namespace {

constexpr int kWidth = 160, kHeight = 120;
constexpr double kFocal = 150.0;

cv::Mat Texture(unsigned seed) {
  cv::Mat noise(kHeight, kWidth, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 1.2);
  cv::normalize(smooth, smooth, 0, 1, cv::NORM_MINMAX);
  return smooth;
}

PosedCamera CameraAt(double x) {
  PosedCamera c;
  c.camera.model_id = CameraModelId::kPinhole;
  c.camera.width = kWidth;
  c.camera.height = kHeight;
  c.camera.params = {kFocal, kFocal, kWidth / 2.0, kHeight / 2.0};
  c.cam_from_world.translation = Eigen::Vector3d(-x, 0, 0);
  return c;
}

// The view from a camera moved by `x` of a scene whose left half is a
// plane at depth z_left and right half one at z_right (fronto-parallel,
// textured as `texture` in the reference view): each half shifts by
// -f x / z pixels.
cv::Mat Shifted(const cv::Mat& texture, double x, double z_left,
                double z_right) {
  cv::Mat out(texture.size(), CV_32F);
  for (int half = 0; half < 2; ++half) {
    const double shift = -kFocal * x / (half == 0 ? z_left : z_right);
    const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, shift, 0, 1, 0);
    cv::Mat moved;
    cv::warpAffine(texture, moved, m, texture.size(), cv::INTER_CUBIC,
                   cv::BORDER_REFLECT);
    const cv::Rect r(half * kWidth / 2, 0, kWidth / 2, kHeight);
    moved(r).copyTo(out(r));
  }
  return out;
}

TEST(PlaneSweepTest, RecoversTwoPlanesWithinTwoPercent) {
  const cv::Mat texture = Texture(1);
  const double z_left = 2.0, z_right = 4.0;
  const StereoView ref{texture, CameraAt(0)};
  const std::vector<StereoView> neighbours = {
      {Shifted(texture, 0.2, z_left, z_right), CameraAt(0.2)},
      {Shifted(texture, -0.2, z_left, z_right), CameraAt(-0.2)}};
  const cv::Mat depth = PlaneSweepDepth(ref, neighbours, 1.0, 8.0);
  int checked = 0, valid = 0;
  for (int y = 20; y < kHeight - 20; ++y) {
    for (int x = 25; x < kWidth - 25; ++x) {
      if (std::abs(x - kWidth / 2) < 12) continue;  // the step's edge
      ++checked;
      const float z = depth.at<float>(y, x);
      if (z == 0) continue;
      ++valid;
      const double expected = x < kWidth / 2 ? z_left : z_right;
      EXPECT_NEAR(z, expected, 0.02 * expected) << x << "," << y;
    }
  }
  EXPECT_GT(valid, 0.95 * checked);
}

TEST(PlaneSweepTest, FlatImagesGiveNoDepth) {
  const cv::Mat flat(kHeight, kWidth, CV_32F, cv::Scalar(0.5));
  const cv::Mat depth =
      PlaneSweepDepth({flat, CameraAt(0)}, {{flat, CameraAt(0.2)}}, 1.0, 8.0);
  EXPECT_EQ(cv::countNonZero(depth), 0);
}

TEST(PlaneSweepTest, BadInputIsAnError) {
  const cv::Mat texture = Texture(2);
  EXPECT_THROW(PlaneSweepDepth({texture, CameraAt(0)}, {}, 1, 8), Error);
  EXPECT_THROW(
      PlaneSweepDepth({texture, CameraAt(0)}, {{texture, CameraAt(0.1)}}, 2, 1),
      Error);
  cv::Mat small;
  cv::resize(texture, small, cv::Size(80, 60));
  EXPECT_THROW(
      PlaneSweepDepth({small, CameraAt(0)}, {{texture, CameraAt(0.1)}}, 1, 8),
      Error);
}

}  // namespace
}  // namespace pano4d
