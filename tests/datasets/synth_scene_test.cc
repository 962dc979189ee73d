#include "src/datasets/synth_scene.h"

#include <gtest/gtest.h>

namespace pano4d::synth {
namespace {

Scene BoxInRoom() {
  Scene scene;
  scene.room_min = {-4, -3, 0};
  scene.room_max = {4, 3, 3};
  Part room;
  room.shape = ShapeKind::kRoom;
  room.half_size = {4, 3, 1.5};
  room.rest = Rigid3d(Eigen::Quaterniond::Identity(), {0, 0, 1.5});
  room.instance = 1;
  Part box;
  box.half_size = {0.5, 0.5, 0.5};
  box.rest = Rigid3d(Eigen::Quaterniond::Identity(), {0, 0, 0.5});
  box.instance = 2;
  box.material = 6;
  scene.parts = {room, box};
  scene.materials.resize(7);
  scene.light_directions = {Eigen::Vector3d::UnitZ()};
  scene.light_intensities = {0.5};
  return scene;
}

TEST(SynthSceneTest, NearestHitAndNormals) {
  const Scene scene = BoxInRoom();
  const PartPoses poses = PosesAt(scene, 0.0);
  // Along +y from (0, -2, 0.5): the box's -y face at y = -0.5.
  const Hit box =
      Intersect(scene, poses, {0, -2, 0.5}, Eigen::Vector3d::UnitY());
  ASSERT_TRUE(box.valid());
  EXPECT_EQ(box.part, 1);
  EXPECT_NEAR(box.distance, 1.5, 1e-12);
  EXPECT_LT((box.normal - Eigen::Vector3d(0, -1, 0)).norm(), 1e-12);
  // Over the box: the room's +y wall, face 3, normal pointing back inside.
  const Hit wall =
      Intersect(scene, poses, {0, -2, 2.0}, Eigen::Vector3d::UnitY());
  EXPECT_EQ(wall.part, 0);
  EXPECT_EQ(wall.face, 3);
  EXPECT_NEAR(wall.distance, 5.0, 1e-12);
  EXPECT_LT((wall.normal - Eigen::Vector3d(0, -1, 0)).norm(), 1e-12);
  // Straight down onto the floor.
  const Hit floor =
      Intersect(scene, poses, {2, 2, 1}, -Eigen::Vector3d::UnitZ());
  EXPECT_EQ(floor.face, 4);
  EXPECT_NEAR(floor.distance, 1.0, 1e-12);
  const Eigen::Vector3d color = Shade(scene, floor);
  EXPECT_TRUE((color.array() >= 0).all() && (color.array() <= 1).all());
}

TEST(SynthSceneTest, BuiltInSceneMovesOnlyWhatIsDynamic) {
  const Scene scene = BuildScene(0, false);
  // Not s = 1: the tube bends with period 1 and is back where it started.
  const PartPoses start = PosesAt(scene, 0.0), end = PosesAt(scene, 0.37);
  int moving = 0, bending = 0;
  for (std::size_t i = 0; i < scene.parts.size(); ++i) {
    const Part& part = scene.parts[i];
    const double moved = (start.world_from_part[i].translation -
                          end.world_from_part[i].translation)
                             .norm() +
                         start.world_from_part[i].rotation.angularDistance(
                             end.world_from_part[i].rotation);
    EXPECT_EQ(part.dynamic, moved > 1e-9) << "part " << i;
    moving += part.dynamic;
    bending += part.motion == MotionKind::kBend;
  }
  EXPECT_GE(moving - bending, 2);  // two rigid movers
  EXPECT_GE(bending, 8);           // the non-rigid tube
}

TEST(SynthSceneTest, TubeBendsWithoutStretching) {
  // Neighbouring tube spheres stay one arc step apart, measured along the
  // arc, at every time: the tube bends, it does not stretch.
  const Scene scene = BuildScene(3, false);
  std::vector<int> tube;
  for (std::size_t i = 0; i < scene.parts.size(); ++i) {
    if (scene.parts[i].motion == MotionKind::kBend)
      tube.push_back(static_cast<int>(i));
  }
  ASSERT_GE(tube.size(), 2u);
  const Part& first = scene.parts[tube[0]];
  const double step = first.length * (scene.parts[tube[1]].u - first.u);
  double max_turn = 0;
  for (double s : {0.0, 0.2, 0.45, 0.7, 1.0}) {
    const PartPoses poses = PosesAt(scene, s);
    for (std::size_t k = 0; k + 1 < tube.size(); ++k) {
      const Rigid3d& a = poses.world_from_part[tube[k]];
      const Rigid3d& b = poses.world_from_part[tube[k + 1]];
      const double turn = a.rotation.angularDistance(b.rotation);
      max_turn = std::max(max_turn, turn);
      // Chord of an arc of length `step` turning by `turn`.
      const double chord =
          turn > 1e-12 ? 2 * step / turn * std::sin(turn / 2) : step;
      EXPECT_NEAR((a.translation - b.translation).norm(), chord, 1e-9);
    }
  }
  EXPECT_GT(max_turn, 0.01);  // it does bend
}

TEST(SynthSceneTest, StaticVariantHasNoMotion) {
  const Scene scene = BuildScene(0, true);
  for (const Part& part : scene.parts) {
    EXPECT_FALSE(part.dynamic);
    EXPECT_EQ(part.motion, MotionKind::kStatic);
  }
}

}  // namespace
}  // namespace pano4d::synth
