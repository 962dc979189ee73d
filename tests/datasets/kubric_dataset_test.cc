#include "src/datasets/kubric_dataset.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "src/core/error.h"
#include "src/core/json.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

// Kubric's camera metadata for a camera at `eye` looking at the origin:
// Blender camera axes (x right, y up, z back), quaternion w, x, y, z.
Json KubricView(const Eigen::Vector3d& eye, int frames) {
  const Eigen::Vector3d forward = (-eye).normalized();
  const Eigen::Vector3d right =
      forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d up = right.cross(forward);
  Eigen::Matrix3d world_from_blender;
  world_from_blender << right, up, -forward;
  const Eigen::Quaterniond q(world_from_blender);
  Json positions = Json::array(), quaternions = Json::array();
  for (int t = 0; t < frames; ++t) {
    positions.push_back({eye.x(), eye.y(), eye.z()});
    quaternions.push_back({q.w(), q.x(), q.y(), q.z()});
  }
  return Json{{"camera",
               {{"K", {{1.0, 0.0, -0.5}, {0.0, -1.5, -0.5}, {0.0, 0.0, -1.0}}},
                {"positions", positions},
                {"quaternions", quaternions}}},
              {"scene",
               {{"resolution", {576, 384}},
                {"num_frames", frames},
                {"frame_rate", 24}}}};
}

TEST(KubricDatasetTest, ViewFourTrainsOthersValidateInOpenCvAxes) {
  testing::TempDir dir;
  std::vector<Eigen::Vector3d> eyes;
  for (int v = 0; v < 6; ++v) {
    eyes.emplace_back(15 * std::cos(0.5 * v), 15 * std::sin(0.5 * v),
                      v < 4 ? 10.0 : 1.3);
    WriteJson(dir / ("scn02900_p0_v" + std::to_string(v) + ".json"),
              KubricView(eyes.back(), 3));
  }
  ASSERT_TRUE(LooksLikeKubric4D(dir.path()));
  const Dataset d = LoadDataset(dir.path(), 1);
  EXPECT_EQ(d.kind, DatasetKind::kKubric4D);
  ASSERT_EQ(d.train.size(), 3u);
  ASSERT_EQ(d.val.size(), 15u);
  EXPECT_EQ(d.num_times, 3);
  EXPECT_DOUBLE_EQ(d.fps, 24.0);
  EXPECT_EQ(d.factor, 1);
  EXPECT_THROW(LoadDataset(dir.path(), 2), Error);  // no 2x files exist
  // The protocol's factor, the default, is Kubric-4D's one resolution.
  EXPECT_EQ(LoadDataset(dir.path(), kProtocolFactor).factor, 1);
  EXPECT_EQ(LoadDataset(dir.path()).factor, 1);
  for (const auto* split : {&d.train, &d.val}) {
    for (const DatasetFrame& f : *split) {
      EXPECT_DOUBLE_EQ(f.camera.camera.focal_x(), 576.0);
      EXPECT_DOUBLE_EQ(f.camera.camera.focal_y(), 576.0);
      EXPECT_LT((f.camera.Center() - eyes[f.camera_id]).norm(), 1e-9);
      EXPECT_LT((*f.camera.Project(Eigen::Vector3d::Zero()) -
                 Eigen::Vector2d(288, 192))
                    .norm(),
                1e-6);
      EXPECT_LT(f.camera.Project(Eigen::Vector3d(0, 0, 1))->y(),
                192);  // up is up
    }
  }
  EXPECT_EQ(d.train[2].id, "v4_t00002");
  EXPECT_EQ(d.train[2].rgb, dir / "frames_p0_v4" / "rgba_00002.png");
  EXPECT_EQ(d.train[2].depth_convention, DepthConvention::kRayDistance);
}

TEST(KubricDatasetTest, MissingTrainingViewAndShortPoseListsAreErrors) {
  testing::TempDir dir;
  WriteJson(dir / "scn1_p0_v0.json", KubricView({5, 0, 1}, 2));
  EXPECT_THROW(LoadDataset(dir.path(), 1), Error);
  Json view = KubricView({5, 0, 1}, 2);
  view["scene"]["num_frames"] = 5;
  WriteJson(dir / "scn1_p0_v4.json", view);
  EXPECT_THROW(LoadDataset(dir.path(), 1), Error);
}

}  // namespace
}  // namespace pano4d
