#include "src/core/camera_check.h"

#include <gtest/gtest.h>

namespace pano4d {
namespace {

TEST(MeasureRoundTripTest, SamplesEdgeToEdgeAndCountsFailures) {
  const Camera pinhole{CameraModelId::kPinhole, 40, 30, {50, 50, 20, 15}};
  const RoundTripStats exact = MeasureRoundTrip(pinhole, 4, 3);
  EXPECT_EQ(exact.samples, 5 * 4);
  EXPECT_EQ(exact.failures, 0);
  EXPECT_LT(exact.max_error_px, 1e-12);
  EXPECT_EQ(exact.mean_iterations, 0.0);  // no distortion, no iterations

  // x_d = x (1 - 0.4 r^2) has no preimage beyond r_d = 0.609. At f = 600 the
  // corners (r_d = 0.667) lie past that, the edge midpoints (0.533, 0.4) do
  // not: exactly the four corners fail.
  const Camera folded{
      CameraModelId::kSimpleRadial, 640, 480, {600, 320, 240, -0.4}};
  const RoundTripStats stats = MeasureRoundTrip(folded, 2, 2);
  EXPECT_EQ(stats.samples, 9);
  EXPECT_EQ(stats.failures, 4);  // the four corners
  EXPECT_GT(stats.mean_iterations, 0.0);
}

}  // namespace
}  // namespace pano4d
