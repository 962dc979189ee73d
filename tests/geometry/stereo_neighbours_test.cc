#include "src/geometry/stereo_neighbours.h"

#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "src/core/error.h"

namespace pano4d {
namespace {

PosedCamera At(double x, double yaw_degrees = 0.0) {
  PosedCamera c;
  c.camera = Camera{CameraModelId::kPinhole, 64, 48, {50, 50, 32, 24}};
  const Eigen::Quaterniond world_from_cam(
      Eigen::AngleAxisd(yaw_degrees * M_PI / 180, Eigen::Vector3d::UnitY()));
  c.cam_from_world.rotation = world_from_cam.conjugate();
  c.cam_from_world.translation =
      -(c.cam_from_world.rotation * Eigen::Vector3d(x, 0, 0));
  return c;
}

// At median depth 1 the baseline is the ratio: the neighbours are those
// nearest 0.08 on a log scale, never one too close or looking away.
TEST(StereoNeighboursTest, BaselineNearestTheRatioFirst) {
  const std::vector<PosedCamera> cameras = {At(0.0),  At(0.005), At(0.05),
                                            At(0.08), At(0.16),  At(0.08, 90.0),
                                            At(0.5)};
  const std::vector<std::size_t> all = SelectStereoNeighbours(cameras, 0, 1.0);
  EXPECT_EQ(all, (std::vector<std::size_t>{3, 2, 4, 6}));
  StereoNeighbourOptions two;
  two.neighbours = 2;
  EXPECT_EQ(SelectStereoNeighbours(cameras, 0, 1.0, two),
            (std::vector<std::size_t>{3, 2}));
  // At ten times the depth the same cameras are ten times too close.
  EXPECT_EQ(SelectStereoNeighbours(cameras, 0, 10.0, two),
            (std::vector<std::size_t>{6, 4}));
  EXPECT_TRUE(SelectStereoNeighbours({At(0.0), At(0.001)}, 0, 1.0).empty());
  EXPECT_THROW(SelectStereoNeighbours(cameras, 0, 0.0), Error);
  EXPECT_THROW(SelectStereoNeighbours(cameras, 7, 1.0), Error);
}

TEST(StereoNeighboursTest, RangeFromTheSparsePoints) {
  std::vector<double> z;
  for (int i = 100; i >= 1; --i) z.push_back(i);  // any order
  const std::optional<StereoRange> r = StereoRangeOf(z);
  ASSERT_TRUE(r);
  EXPECT_DOUBLE_EQ(r->near, kStereoNearMargin * 3);  // the 2nd percentile
  EXPECT_DOUBLE_EQ(r->far, kStereoFarMargin * 99);   // the 98th
  EXPECT_DOUBLE_EQ(r->median, 51);
  z.resize(kMinStereoPoints - 1);
  EXPECT_FALSE(StereoRangeOf(z));
}

}  // namespace
}  // namespace pano4d
