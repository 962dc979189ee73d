#include "src/geometry/inpaint.h"

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

// A smooth ramp with a hole, including one touching the top-left corner:
// what Debian's OpenCV 4.6 gets wrong on float images (values far outside
// the ramp's range).
TEST(InpaintTest, FillsARampWithinItsRange) {
  cv::Mat ramp(24, 32, CV_32FC3);
  for (int y = 0; y < ramp.rows; ++y)
    for (int x = 0; x < ramp.cols; ++x)
      ramp.at<cv::Vec3f>(y, x) = cv::Vec3f(0.9f * x / 31, 0.5f, 0.9f * y / 23);
  cv::Mat mask(ramp.size(), CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(10, 8, 8, 6)).setTo(255);
  mask(cv::Rect(0, 0, 4, 3)).setTo(255);
  cv::Mat holed = ramp.clone();
  holed.setTo(cv::Scalar::all(7), mask);  // garbage in the hole
  const cv::Mat out = InpaintTelea(holed, mask, 1.0, 3.0);
  ASSERT_EQ(out.type(), CV_32FC3);
  double worst = 0;
  for (int y = 0; y < ramp.rows; ++y) {
    for (int x = 0; x < ramp.cols; ++x) {
      const double e = cv::norm(
          out.at<cv::Vec3f>(y, x) - ramp.at<cv::Vec3f>(y, x), cv::NORM_INF);
      if (mask.at<std::uint8_t>(y, x)) {
        worst = std::max(worst, e);
      } else {
        EXPECT_LT(e, 1e-4) << x << "," << y;  // known pixels kept
      }
    }
  }
  EXPECT_LT(worst, 0.15);  // a smooth guess, within the ramp's range
}

TEST(InpaintTest, RefusesWhatItCannotInpaint) {
  const cv::Mat image(4, 4, CV_32FC1, cv::Scalar(1));
  EXPECT_THROW(InpaintTelea(image, cv::Mat(3, 4, CV_8UC1), 1, 3), Error);
  EXPECT_THROW(
      InpaintTelea(cv::Mat(4, 4, CV_8UC1), cv::Mat(4, 4, CV_8UC1), 1, 3),
      Error);
  EXPECT_THROW(InpaintTelea(image, cv::Mat(4, 4, CV_8UC1), 0, 3), Error);
}

// A disocclusion: a near object (depth 1) beside a far wall (depth 5) with a
// hole between them. The hole takes the wall's depth, not a mix.
TEST(InpaintTest, DepthHolesTakeTheFarthestSurfaceAround) {
  cv::Mat depth(10, 20, CV_32FC1, cv::Scalar(5));
  depth(cv::Rect(0, 0, 6, 10)).setTo(1);
  cv::Mat mask(depth.size(), CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(6, 2, 5, 6)).setTo(255);
  depth.setTo(0, mask);
  const cv::Mat out = FillDepthFromFarthest(depth, mask);
  for (int y = 2; y < 8; ++y)
    for (int x = 6; x < 11; ++x) EXPECT_EQ(out.at<float>(y, x), 5.0f);
  EXPECT_EQ(out.at<float>(5, 2), 1.0f);  // known pixels kept
  // Nothing known: nothing to fill from.
  const cv::Mat none =
      FillDepthFromFarthest(cv::Mat(4, 4, CV_32FC1, cv::Scalar(0)),
                            cv::Mat(4, 4, CV_8UC1, cv::Scalar(0)));
  EXPECT_EQ(cv::countNonZero(none), 0);
}

}  // namespace
}  // namespace pano4d
