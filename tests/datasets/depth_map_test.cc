#include "src/datasets/depth_map.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "src/core/error.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

Camera Pinhole() {
  return Camera{CameraModelId::kPinhole, 40, 30, {30, 32, 20, 15}};
}

// A plane at z = 2 as Kubric stores it (distance along each ray) reads
// back as z = 2 everywhere.
TEST(DepthMapTest, KubricRayDistanceBecomesZ) {
  testing::TempDir dir;
  const Camera camera = Pinhole();
  cv::Mat distance(camera.height, camera.width, CV_32F);
  for (int y = 0; y < distance.rows; ++y)
    for (int x = 0; x < distance.cols; ++x) {
      const double xn = (x + 0.5 - 20) / 30, yn = (y + 0.5 - 15) / 32;
      distance.at<float>(y, x) =
          static_cast<float>(2 * std::sqrt(xn * xn + yn * yn + 1));
    }
  WriteDepthMap(dir / "d.npy", distance);
  DatasetFrame frame;
  frame.depth = dir / "d.npy";
  frame.camera.camera = camera;
  frame.depth_convention = DepthConvention::kRayDistance;
  double worst = 0;
  const cv::Mat z = ReadDepth(frame);
  for (auto it = z.begin<float>(); it != z.end<float>(); ++it)
    worst = std::max(worst, std::abs(*it - 2.0));
  EXPECT_LT(worst, 1e-6);
  // The same file as z-depth is left as it is: off-axis it is farther.
  frame.depth_convention = DepthConvention::kZ;
  EXPECT_GT(ReadDepth(frame).at<float>(0, 0), 2.1f);
}

TEST(DepthMapTest, NonFiniteAndNegativeBecomeNoDepthAndMillimetresMetres) {
  testing::TempDir dir;
  cv::Mat d(2, 3, CV_32F, cv::Scalar(1.5f));
  d.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  d.at<float>(0, 1) = -3;
  d.at<float>(1, 2) = std::numeric_limits<float>::infinity();
  WriteDepthMap(dir / "d.npy", d);
  const cv::Mat read = ReadDepthMap(dir / "d.npy");
  EXPECT_EQ(read.at<float>(0, 0), 0);
  EXPECT_EQ(read.at<float>(0, 1), 0);
  EXPECT_EQ(read.at<float>(1, 2), 0);
  EXPECT_EQ(read.at<float>(1, 0), 1.5f);
  cv::Mat mm(2, 2, CV_16U, cv::Scalar(2500));
  cv::imwrite((dir / "mm.png").string(), mm);
  EXPECT_FLOAT_EQ(ReadDepthMap(dir / "mm.png").at<float>(1, 1), 2.5f);
}

TEST(DepthMapTest, ASizeOtherThanTheCameraNamesTheFile) {
  testing::TempDir dir;
  WriteDepthMap(dir / "small.npy", cv::Mat(3, 4, CV_32F, cv::Scalar(1.0f)));
  DatasetFrame frame;
  frame.depth = dir / "small.npy";
  frame.camera.camera = Pinhole();
  try {
    ReadDepth(frame);
    FAIL() << "a 4x3 map was read for a 40x30 camera";
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), (dir / "small.npy").string());
    EXPECT_EQ(e.value(), "4x3");
  }
}

}  // namespace
}  // namespace pano4d
