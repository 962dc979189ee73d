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
    EXPECT_LT(worst, 0.06) << degrees << " deg";  // triangles, not bilinear
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
// and the triangles between them cover every pixel.
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

// A plane through (0, 0, 4) whose normal is tilted `degrees` about the y axis
// away from the source camera's axis (the source at the origin).
struct TiltedPlane {
  Eigen::Vector3f normal, point{0, 0, 4};
  explicit TiltedPlane(float degrees)
      : normal(std::sin(degrees * float(M_PI) / 180), 0,
               -std::cos(degrees * float(M_PI) / 180)) {}
  // z-depth in `c` of the plane under pixel (x, y); 0 when the ray misses.
  float Depth(const RasterCamera& c, float x, float y) const {
    const Eigen::Vector3f ray_cam((x + 0.5f - c.cx) / c.fx,
                                  (y + 0.5f - c.cy) / c.fy, 1);
    const Eigen::Vector3f centre = c.Center();
    const Eigen::Vector3f ray = c.rotation.transpose() * ray_cam;
    const float s = normal.dot(point - centre) / normal.dot(ray);
    return s > 0 ? s : 0;  // ray_cam's z is 1: s is the z-depth
  }
  cv::Mat DepthMap(const RasterCamera& c) const {
    cv::Mat depth(c.height, c.width, CV_32F);
    for (int y = 0; y < c.height; ++y)
      for (int x = 0; x < c.width; ++x) depth.at<float>(y, x) = Depth(c, x, y);
    return depth;
  }
};

// The target pixels whose plane point the source sees at least `margin`
// pixels inside its image, as a mask.
cv::Mat SeenBySource(const TiltedPlane& plane, const RasterCamera& src,
                     const RasterCamera& dst, float margin) {
  cv::Mat seen(dst.height, dst.width, CV_8U, cv::Scalar(0));
  for (int y = 0; y < dst.height; ++y) {
    for (int x = 0; x < dst.width; ++x) {
      const float z = plane.Depth(dst, x, y);
      if (!(z > 0)) continue;
      const Eigen::Vector3f p_cam((x + 0.5f - dst.cx) / dst.fx * z,
                                  (y + 0.5f - dst.cy) / dst.fy * z, z);
      const Eigen::Vector3f world =
          dst.rotation.transpose() * (p_cam - dst.translation);
      const Eigen::Vector3f q = src.rotation * world + src.translation;
      const float u = src.fx * q.x() / q.z() + src.cx;
      const float v = src.fy * q.y() / q.z() + src.cy;
      if (u > margin && v > margin && u < src.width - margin &&
          v < src.height - margin)
        seen.at<std::uint8_t>(y, x) = 255;
    }
  }
  return seen;
}

// A plane at 65 degrees (depth steps 3% a pixel) seen 3.6 times closer:
// landings of neighbouring pixels fall about 3.6 target pixels apart, with
// depths that differ by more than the old splat's 2% band, so its cracks
// stayed (2360 of the pixels checked here).
// The mesh keeps it whole, at the plane's own depth.
TEST(WarpTest, TiltedPlaneMagnifiedThreeToFourTimesStaysWhole) {
  const RasterCamera src = Camera();
  const TiltedPlane plane(65);
  const cv::Mat rgb = Texture(src.width, src.height);
  const cv::Mat depth = plane.DepthMap(src);
  RasterCamera dst = src;
  dst.translation.z() = -2.9f;  // 1.1 from the plane's centre: 4 / 1.1
  const WarpResult w = ForwardWarp(rgb, depth, src, dst);
  const cv::Mat seen = SeenBySource(plane, src, dst, 1.0f);
  ASSERT_GT(cv::countNonZero(seen), dst.width * dst.height / 4);
  EXPECT_EQ(cv::countNonZero(seen & w.mask), 0);
  double worst = 0;
  for (int y = 0; y < dst.height; ++y)
    for (int x = 0; x < dst.width; ++x)
      if (seen.at<std::uint8_t>(y, x))
        worst = std::max(
            worst,
            std::abs(w.depth.at<float>(y, x) / plane.Depth(dst, x, y) - 1.0));
  EXPECT_LT(worst, 1e-4);  // the mesh's triangles lie in the plane
  EXPECT_LT(CrackFraction(w.mask), 0.01);
}

// Depth with 3% Gaussian noise, independent per pixel (neighbours differ by
// 3.4% on average, more than the old splat's 2% band: it left 466 holes
// here), a tilted plane seen 1.5 times closer from 15 degrees to the side:
// no triangle may break or be left out inside it.
TEST(WarpTest, NoisyDepthPlaneStaysWhole) {
  const RasterCamera src = Camera();
  const TiltedPlane plane(30);
  const cv::Mat rgb = Texture(src.width, src.height);
  cv::Mat depth = plane.DepthMap(src);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0, 0.03f);
  for (int y = 0; y < src.height; ++y)
    for (int x = 0; x < src.width; ++x) depth.at<float>(y, x) *= 1 + noise(rng);
  // Orbit 15 degrees about the plane's centre, 1.5 times closer to it.
  RasterCamera dst = src;
  dst.rotation =
      Eigen::AngleAxisf(15 * float(M_PI) / 180, Eigen::Vector3f::UnitY())
          .toRotationMatrix();
  const Eigen::Vector3f centre =
      plane.point - dst.rotation.transpose() * Eigen::Vector3f(0, 0, 4 / 1.5f);
  dst.translation = -dst.rotation * centre;
  const WarpResult w = ForwardWarp(rgb, depth, src, dst);
  // A margin of 3 pixels: the noise moves the source's border by up to 1.
  const cv::Mat seen = SeenBySource(plane, src, dst, 3.0f);
  ASSERT_GT(cv::countNonZero(seen), dst.width * dst.height / 4);
  EXPECT_EQ(cv::countNonZero(seen & w.mask), 0);
  EXPECT_LT(CrackFraction(w.mask), 0.01);
}

// A camera 4 from the plane's centre, facing it along its normal.
RasterCamera Facing(const TiltedPlane& plane, const RasterCamera& like) {
  RasterCamera c = like;
  const Eigen::Vector3f z = -plane.normal, y(0, 1, 0);
  c.rotation.row(0) = y.cross(z);
  c.rotation.row(1) = y;
  c.rotation.row(2) = z;
  c.translation = -c.rotation * (plane.point + 4 * plane.normal);
  return c;
}

// A surface the source saw nearly edge-on (84 degrees from its normal: a
// pixel of it covers ten of a camera that faces it) holds nothing for that
// camera: it is left out as one hole, not smeared. At 60 degrees (twice)
// it is kept whole.
TEST(WarpTest, SurfaceSeenEdgeOnIsLeftOutForACameraFacingIt) {
  const RasterCamera src = Camera();
  const cv::Mat rgb = Texture(src.width, src.height);
  for (float degrees : {60.0f, 84.0f}) {
    const TiltedPlane plane(degrees);
    const RasterCamera dst = Facing(plane, src);
    const WarpResult w = ForwardWarp(rgb, plane.DepthMap(src), src, dst);
    const cv::Mat seen = SeenBySource(plane, src, dst, 2.0f);
    const int inside = cv::countNonZero(seen);
    ASSERT_GT(inside, 100) << degrees;
    const int holes = cv::countNonZero(seen & w.mask);
    if (degrees < 70) {
      EXPECT_EQ(holes, 0) << degrees;
    } else {
      EXPECT_GT(holes, 0.95 * inside) << degrees;
    }
    EXPECT_LT(CrackFraction(w.mask), 0.02) << degrees;
  }
}

// A box at 2 m in front of a wall at 10 m, the camera moved 0.3 m right:
// the box shifts fx 0.3 / 2 = 10.5 px left, the wall 2.1 px, so each of the
// box's rows uncovers 8.4 px of wall the source could not see. The hole
// keeps that width; it is not bridged from the box to the wall.
TEST(WarpTest, DisocclusionBesideABoxHasTheParallaxWidth) {
  const RasterCamera src = Camera();
  const cv::Mat rgb = Texture(src.width, src.height);
  cv::Mat depth(src.height, src.width, CV_32F, cv::Scalar(10));
  const cv::Rect box(30, 20, 20, 20);
  depth(box).setTo(2);
  RasterCamera dst = src;
  dst.translation.x() = -0.3f;
  const WarpResult w = ForwardWarp(rgb, depth, src, dst);
  // The box's last pixel (49 to 50) lands on 38.5 to 39.5, the wall's first
  // (50 to 51) on 47.9 to 48.9: the centres 40.5 ... 47.5 between them are
  // holes.
  for (int y = box.y + 1; y < box.br().y - 1; ++y) {
    int run = 0;
    for (int x = 36; x < 56; ++x) run += w.mask.at<std::uint8_t>(y, x) != 0;
    EXPECT_EQ(run, 8) << "row " << y;
    EXPECT_NE(w.mask.at<std::uint8_t>(y, 40), 0) << "row " << y;
    EXPECT_NE(w.mask.at<std::uint8_t>(y, 47), 0) << "row " << y;
    EXPECT_NEAR(w.depth.at<float>(y, 39), 2.0f, 1e-3) << "row " << y;
    EXPECT_NEAR(w.depth.at<float>(y, 48), 10.0f, 1e-3) << "row " << y;
  }
  // A hole 9 px wide is not a crack.
  EXPECT_EQ(CountCracks(w.mask(cv::Rect(0, 0, 70, src.height))), 0);
}

// A one-pixel line in front of a wall breaks every triangle it is part of;
// it still lands (its pixels' footprints), in front of the wall.
TEST(WarpTest, OnePixelStructuresSurvive) {
  const RasterCamera src = Camera();
  const cv::Mat rgb = Texture(src.width, src.height);
  cv::Mat depth(src.height, src.width, CV_32F, cv::Scalar(10));
  depth.col(40).setTo(2);
  const WarpResult same = ForwardWarp(rgb, depth, src, src);
  EXPECT_EQ(cv::countNonZero(same.mask), 0);
  EXPECT_FLOAT_EQ(same.depth.at<float>(30, 40), 2.0f);
  RasterCamera dst = src;
  dst.translation.x() = -0.09f;  // the line (40.5) lands at 37.35
  const WarpResult w = ForwardWarp(rgb, depth, src, dst);
  for (int y = 5; y < 55; ++y) {
    EXPECT_EQ(w.mask.at<std::uint8_t>(y, 37), 0) << "row " << y;
    EXPECT_NEAR(w.depth.at<float>(y, 37), 2.0f, 1e-4) << "row " << y;
  }
}

// The crack measure: a lace of one-pixel gaps is nearly all cracks; a wide
// hole and a band out of view are none.
TEST(WarpTest, CrackFractionSeparatesLaceFromWideHoles) {
  cv::Mat lace(60, 80, CV_8U, cv::Scalar(0));
  for (int y = 10; y < 50; y += 3) lace.row(y).colRange(10, 70).setTo(255);
  for (int x = 10; x < 70; x += 4) lace.col(x).rowRange(10, 50).setTo(255);
  EXPECT_GT(CrackFraction(lace), 0.95);
  cv::Mat wide(60, 80, CV_8U, cv::Scalar(0));
  wide(cv::Rect(20, 15, 12, 20)).setTo(255);  // a disocclusion
  wide.colRange(76, 80).setTo(255);           // out of view
  wide.rowRange(0, 2).setTo(255);
  EXPECT_EQ(CountCracks(wide), 0);
  EXPECT_EQ(CrackFraction(wide), 0.0);
  EXPECT_EQ(CrackFraction(cv::Mat(4, 4, CV_8U, cv::Scalar(0))), 0.0);
  // Gaps of 5 pixels and more are not cracks at the default kernel.
  cv::Mat gap(20, 20, CV_8U, cv::Scalar(0));
  gap(cv::Rect(8, 5, 4, 10)).setTo(255);
  EXPECT_EQ(CountCracks(gap), 4 * 10);
  gap(cv::Rect(8, 5, 5, 10)).setTo(255);
  EXPECT_EQ(CountCracks(gap), 0);
  EXPECT_THROW(CountCracks(cv::Mat(4, 4, CV_32F)), Error);
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
