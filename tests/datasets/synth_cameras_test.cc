#include "src/datasets/synth_cameras.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "src/core/error.h"

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

// The camera's path length and the largest angle between two of its views.
std::pair<double, double> PathAndTurn(const std::vector<PosedCamera>& c) {
  double path = 0, turn = 0;
  for (std::size_t t = 0; t < c.size(); ++t) {
    if (t > 0) path += (c[t].Center() - c[t - 1].Center()).norm();
    turn = std::max(turn, c[t].cam_from_world.rotation.angularDistance(
                              c[0].cam_from_world.rotation));
  }
  return {path, turn * 180 / M_PI};
}

TEST(SynthCamerasTest, SlowArcPanAndStaticCameraMoveAsNamed) {
  const Scene scene = BuildScene(0, false);
  const auto [arc_path, arc_turn] =
      PathAndTurn(TrainingTrajectory(scene, kCamera, 48, 0));
  const auto [slow_path, slow_turn] = PathAndTurn(
      TrainingTrajectory(scene, kCamera, 48, 0, TrainingMotion::kSlowArc));
  EXPECT_NEAR(slow_path, arc_path / 8, arc_path / 16);
  EXPECT_LT(slow_turn, arc_turn / 4);
  // A pan: one centre, turning through the arc's sweep.
  const std::vector<PosedCamera> pan =
      TrainingTrajectory(scene, kCamera, 48, 0, TrainingMotion::kPan);
  const auto [pan_path, pan_turn] = PathAndTurn(pan);
  EXPECT_LT(pan_path, 1e-9);
  EXPECT_NEAR(pan_turn, 2 * scene.layout.training_half_sweep_degrees, 3.0);
  const auto [still_path, still_turn] = PathAndTurn(
      TrainingTrajectory(scene, kCamera, 48, 0, TrainingMotion::kStatic));
  EXPECT_LT(still_path, 1e-9);
  EXPECT_LT(still_turn, 1e-6);
  for (const TrainingMotion m : {TrainingMotion::kArc, TrainingMotion::kSlowArc,
                                 TrainingMotion::kPan, TrainingMotion::kStatic})
    EXPECT_EQ(TrainingMotionFromName(TrainingMotionName(m)), m);
  EXPECT_THROW(TrainingMotionFromName("dolly"), Error);
}

TEST(SynthCamerasTest, VariedLayoutsMoveTheCamerasOffTheDefaultPlaces) {
  // The default layout is the built-in scene's: validation cameras 75
  // degrees to either side at 1.15 and 1.85 m.
  const Scene fixed = BuildScene(0, false);
  EXPECT_TRUE(fixed.layout.IsDefault());
  EXPECT_NEAR(ValidationCamera(fixed, kCamera, 1).Center().z(), 1.15, 1e-12);
  EXPECT_NEAR(ValidationCamera(fixed, kCamera, 2).Center().z(), 1.85, 1e-12);
  // Over varied seeds the validation cameras' azimuths and heights spread
  // over the ranges VariedLayout promises, and every camera still sees the
  // target.
  double min_height = 10, max_height = 0, min_azimuth = 180, max_azimuth = 0;
  int near_objects = 0;
  for (std::uint32_t seed = 0; seed < 40; ++seed) {
    const Layout layout = VariedLayout(seed);
    EXPECT_FALSE(layout.IsDefault());
    const Scene scene = BuildScene(seed, false, 1.0, layout);
    near_objects += layout.near_object_camera != 0;
    for (int index : {1, 2}) {
      const PosedCamera c = ValidationCamera(scene, kCamera, index);
      const double azimuth =
          std::abs(layout.validation_azimuth_degrees[index - 1]);
      min_height = std::min(min_height, c.Center().z());
      max_height = std::max(max_height, c.Center().z());
      min_azimuth = std::min(min_azimuth, azimuth);
      max_azimuth = std::max(max_azimuth, azimuth);
      const std::optional<Eigen::Vector2d> target = c.Project(scene.target);
      ASSERT_TRUE(target.has_value());
      EXPECT_LT((*target - Eigen::Vector2d(240, 180)).norm(), 1e-6);
      // Inside the room.
      EXPECT_TRUE((c.Center().array() > scene.room_min.array()).all() &&
                  (c.Center().array() < scene.room_max.array()).all())
          << "seed " << seed << " camera " << index;
    }
  }
  EXPECT_LT(min_height, 0.9);
  EXPECT_GT(max_height, 2.1);
  EXPECT_LT(min_azimuth, 50.0);
  EXPECT_GT(max_azimuth, 80.0);
  EXPECT_GT(near_objects, 20);
  EXPECT_LT(near_objects, 40);
}

TEST(SynthCamerasTest, TheNearObjectStandsBetweenItsCameraAndTheTarget) {
  std::uint32_t seed = 0;
  while (VariedLayout(seed).near_object_camera == 0) ++seed;
  const Layout layout = VariedLayout(seed);
  const Scene scene = BuildScene(seed, false, 1.0, layout);
  const Scene without = BuildScene(seed, false, 1.0, [&] {
    Layout l = layout;
    l.near_object_camera = 0;
    return l;
  }());
  ASSERT_EQ(scene.parts.size(), without.parts.size() + 1);
  const Part& near = scene.parts.back();
  EXPECT_FALSE(near.dynamic);
  const Eigen::Vector3d eye = ValidationEye(scene, layout.near_object_camera);
  const Eigen::Vector3d at = near.rest.translation;
  // On the floor, on the camera's line to the target in plan, at the
  // distance the layout drew.
  const Eigen::Vector2d to_target = (scene.target - eye).head<2>().normalized();
  const Eigen::Vector2d to_object = (at - eye).head<2>();
  EXPECT_LT(
      std::abs(to_target.x() * to_object.y() - to_target.y() * to_object.x()),
      1e-9);
  EXPECT_GT(to_object.dot(to_target), 0.0);
  EXPECT_NEAR(at.z(), near.half_size.z(), 1e-12);
  // The other parts are the same scene.
  for (std::size_t i = 0; i + 1 < scene.parts.size(); ++i)
    EXPECT_TRUE(scene.parts[i].rest.translation.isApprox(
        without.parts[i].rest.translation))
        << "part " << i;
}

}  // namespace
}  // namespace pano4d::synth
