#include "src/pano/warp.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

RasterCamera Camera(int w = 80, int h = 60) {
  RasterCamera c;
  c.width = w;
  c.height = h;
  c.fx = c.fy = 70;
  c.cx = w / 2.0f;
  c.cy = h / 2.0f;
  return c;
}

// A smooth texture, so that a bilinear look-up is a fair reference.
cv::Mat Texture(int w, int h) {
  cv::Mat rgb(h, w, CV_32FC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      rgb.at<cv::Vec3f>(y, x) = cv::Vec3f(
          0.5f + 0.4f * std::sin(x * 0.21f), 0.5f + 0.4f * std::cos(y * 0.17f),
          0.5f + 0.3f * std::sin((x + y) * 0.09f));
  return rgb;
}

TEST(WarpTest, OwnCameraIsTheIdentityWithAnEmptyMask) {
  const RasterCamera c = Camera();
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0, 1), z(1, 5);
  cv::Mat rgb(c.height, c.width, CV_32FC3), depth(c.height, c.width, CV_32F);
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      rgb.at<cv::Vec3f>(y, x) = cv::Vec3f(u(rng), u(rng), u(rng));
      depth.at<float>(y, x) = z(rng);  // rough on purpose
    }
  RasterCamera posed = c;
  posed.rotation =
      Eigen::AngleAxisf(0.4f, Eigen::Vector3f(1, 2, 3).normalized())
          .toRotationMatrix();
  posed.translation = Eigen::Vector3f(0.3f, -1, 2);
  const WarpResult w = ForwardWarp(rgb, depth, posed, posed);
  EXPECT_EQ(cv::countNonZero(w.mask), 0);
  EXPECT_LT(cv::norm(w.rgb, rgb, cv::NORM_INF), 1e-4);
  EXPECT_LT(cv::norm(w.depth, depth, cv::NORM_INF), 1e-4);
}

TEST(WarpTest, PureRotationLeavesNoHolesInsideTheOverlap) {
  const RasterCamera src = Camera();
  const cv::Mat rgb = Texture(src.width, src.height);
  for (float degrees : {3.0f, 8.0f, -12.0f}) {
    RasterCamera dst = src;
    dst.rotation =
        Eigen::AngleAxisf(degrees * float(M_PI) / 180,
                          Eigen::Vector3f(0.3f, 1, 0.2f).normalized())
            .toRotationMatrix();
    // Depth does not matter under a pure rotation; vary it anyway.
    cv::Mat depth(src.height, src.width, CV_32F);
    for (int y = 0; y < src.height; ++y)
      for (int x = 0; x < src.width; ++x) depth.at<float>(y, x) = 2 + 0.01f * x;
    const WarpResult w = ForwardWarp(rgb, depth, src, dst);
    int inside = 0, holes = 0;
    double worst = 0;
    for (int y = 0; y < dst.height; ++y) {
      for (int x = 0; x < dst.width; ++x) {
        // Where this target pixel's ray meets the source image.
        const Eigen::Vector3f ray((x + 0.5f - dst.cx) / dst.fx,
                                  (y + 0.5f - dst.cy) / dst.fy, 1);
        const Eigen::Vector3f p = src.rotation * dst.rotation.transpose() * ray;
        if (p.z() <= 0) continue;
        const float u = src.fx * p.x() / p.z() + src.cx;
        const float v = src.fy * p.y() / p.z() + src.cy;
        if (u < 1.5f || v < 1.5f || u > src.width - 1.5f ||
            v > src.height - 1.5f)
          continue;
        ++inside;
        if (w.mask.at<std::uint8_t>(y, x)) {
          ++holes;
          continue;
        }
        cv::Mat expected;
        cv::getRectSubPix(rgb, {1, 1}, cv::Point2f(u - 0.5f, v - 0.5f),
                          expected, CV_32F);
        worst = std::max(worst, cv::norm(w.rgb.at<cv::Vec3f>(y, x) -
                                             expected.at<cv::Vec3f>(0, 0),
                                         cv::NORM_INF));
      }
    }
    EXPECT_GT(inside, src.width * src.height / 2) << degrees;
    EXPECT_EQ(holes, 0) << degrees << " deg";
    EXPECT_LT(worst, 0.06) << degrees << " deg";  // a splat blurs by < 1 px
  }
}

// A near square in front of a far wall, seen by a camera that moves right:
// the square occludes the wall where both land, and uncovers a hole behind.
TEST(WarpTest, NearestSurfaceWinsAndDisocclusionsAreHoles) {
  const RasterCamera src = Camera();
  cv::Mat rgb(src.height, src.width, CV_32FC3, cv::Scalar(0, 0, 1));  // wall
  cv::Mat depth(src.height, src.width, CV_32F, cv::Scalar(10));
  const cv::Rect square(30, 20, 20, 20);
  rgb(square).setTo(cv::Scalar(1, 0, 0));
  depth(square).setTo(2);
  RasterCamera dst = src;
  dst.translation.x() = -0.3f;  // camera centre at x = +0.3
  const WarpResult w = ForwardWarp(rgb, depth, src, dst);
  // The square shifts left by fx * 0.3 / 2 = 10.5 px, the wall by 2.1 px.
  const cv::Vec3f centre = w.rgb.at<cv::Vec3f>(30, 29);
  EXPECT_NEAR(centre[0], 1.0f, 1e-5);
  EXPECT_NEAR(w.depth.at<float>(30, 29), 2.0f, 1e-4);
  // Right of the shifted square: wall the source camera could not see.
  int holes = 0;
  for (int x = 41; x < 47; ++x) holes += w.mask.at<std::uint8_t>(30, x) != 0;
  EXPECT_GE(holes, 4);
  EXPECT_EQ(w.mask.at<std::uint8_t>(30, 60), 0);
  EXPECT_NEAR(w.rgb.at<cv::Vec3f>(30, 60)[2], 1.0f, 1e-5);
  // The image's right edge: nothing came from beyond the source's border.
  EXPECT_NE(w.mask.at<std::uint8_t>(30, 79), 0);
}

// A textured wall seen twice as close: the landings spread two pixels apart,
// and the cracks between them are filled.
TEST(WarpTest, MagnifiedSurfaceHasNoCracks) {
  const RasterCamera src = Camera();
  const cv::Mat rgb = Texture(src.width, src.height);
  const cv::Mat depth(src.height, src.width, CV_32F, cv::Scalar(4));
  RasterCamera dst = src;
  dst.translation.z() = -2;  // camera centre 2 closer: magnification 2
  const WarpResult w = ForwardWarp(rgb, depth, src, dst);
  // The source's border lands 2 x (its distance from the centre) away: the
  // middle half of the target is inside it.
  const cv::Rect inside(src.width / 4 + 2, src.height / 4 + 2,
                        src.width / 2 - 4, src.height / 2 - 4);
  EXPECT_EQ(cv::countNonZero(w.mask(inside)), 0);
  EXPECT_NEAR(cv::mean(w.depth(inside))[0], 2.0, 1e-4);
}

TEST(WarpTest, ValidMaskAndChaining) {
  const RasterCamera c = Camera(20, 10);
  const cv::Mat rgb = Texture(20, 10);
  const cv::Mat depth(10, 20, CV_32F, cv::Scalar(3));
  cv::Mat valid(10, 20, CV_8U, cv::Scalar(1));
  valid(cv::Rect(0, 0, 10, 10)).setTo(0);
  WarpResult half = ForwardWarp(rgb, depth, c, c, valid);
  EXPECT_EQ(cv::countNonZero(half.mask), 100);
  const WarpResult full = ForwardWarp(rgb, depth, c, c);
  WarpResult other{full.rgb.clone(), full.depth.clone(), full.mask.clone()};
  other.rgb.setTo(cv::Scalar(0, 1, 0));
  EXPECT_EQ(FillHoles(other, &half), 100);
  EXPECT_EQ(cv::countNonZero(half.mask), 0);
  EXPECT_EQ(half.rgb.at<cv::Vec3f>(5, 2), cv::Vec3f(0, 1, 0));  // filled
  EXPECT_EQ(half.rgb.at<cv::Vec3f>(5, 15), full.rgb.at<cv::Vec3f>(5, 15));
}

TEST(WarpTest, MismatchedInputsNameTheField) {
  const RasterCamera c = Camera(20, 10);
  const cv::Mat rgb = Texture(20, 10);
  const cv::Mat depth(10, 20, CV_32F, cv::Scalar(3));
  EXPECT_THROW(ForwardWarp(Texture(21, 10), depth, c, c), Error);
  EXPECT_THROW(ForwardWarp(rgb, cv::Mat(10, 20, CV_64F), c, c), Error);
  EXPECT_THROW(ForwardWarp(rgb, depth, c, c, cv::Mat(9, 20, CV_8U)), Error);
  try {
    ForwardWarp(rgb, cv::Mat(5, 5, CV_32F), c, c);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("depth"), std::string::npos);
  }
}

}  // namespace
}  // namespace pano4d
