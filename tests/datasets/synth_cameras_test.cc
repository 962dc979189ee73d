#include "src/datasets/synth_cameras.h"

#include <gtest/gtest.h>

namespace pano4d::synth {
namespace {

const Camera kCamera{CameraModelId::kPinhole, 480, 360, {432, 432, 240, 180}};

TEST(SynthCamerasTest, LookAtCentresTheTargetWithUpUp) {
  const PosedCamera c = LookAt(kCamera, {1, -2, 1.5}, {0, 1, 0.5});
  EXPECT_LT((*c.Project({0, 1, 0.5}) - Eigen::Vector2d(240, 180)).norm(), 1e-9);
  EXPECT_LT((c.Center() - Eigen::Vector3d(1, -2, 1.5)).norm(), 1e-12);
  // A point above the target appears above it in the image (smaller y).
  EXPECT_LT(c.Project({0, 1, 1.5})->y(), 180);
}

TEST(SynthCamerasTest,
     TrainingIsASmoothInwardArcAndValidationLooksFromElsewhere) {
  const Scene scene = BuildScene(0, false);
  const std::vector<PosedCamera> train =
      TrainingTrajectory(scene, kCamera, 48, 0);
  ASSERT_EQ(train.size(), 48u);
  double path = 0;
  for (std::size_t t = 0; t + 1 < train.size(); ++t) {
    const double step = (train[t + 1].Center() - train[t].Center()).norm();
    EXPECT_LT(step, 0.1);  // smooth, handheld pace
    path += step;
  }
  EXPECT_GT(path, 2.0);  // but it does travel
  for (const PosedCamera& c : train) {
    const std::optional<Eigen::Vector2d> target = c.Project(scene.target);
    ASSERT_TRUE(target.has_value());  // inward-facing
    EXPECT_LT((*target - Eigen::Vector2d(240, 180)).norm(), 60);
  }
  const Eigen::Vector3d mid = train[24].Center() - scene.target;
  for (int index : {1, 2}) {
    const Eigen::Vector3d v =
        ValidationCamera(scene, kCamera, index).Center() - scene.target;
    const double angle =
        std::acos(mid.head<2>().normalized().dot(v.head<2>().normalized()));
    EXPECT_GT(angle * 180 / M_PI, 60.0);
  }
}

}  // namespace
}  // namespace pano4d::synth
