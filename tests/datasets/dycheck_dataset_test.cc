#include "src/datasets/dycheck_dataset.h"

#include <random>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/datasets/dataset.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

DyCheckScene RandomScene(int train_frames, int val_frames) {
  std::mt19937 rng(4);
  std::normal_distribution<double> n;
  DyCheckScene scene;
  const Camera camera{
      CameraModelId::kPinhole, 128, 96, {110.25, 110.25, 64.125, 47.875}};
  const auto frame = [&](int camera_id, int time_id) {
    return DyCheckScene::Frame{
        camera_id, time_id,
        PosedCamera{camera,
                    Rigid3d::FromColmap({n(rng), n(rng), n(rng), n(rng)},
                                        {n(rng), n(rng), n(rng)})}};
  };
  for (int t = 0; t < train_frames; ++t) scene.train.push_back(frame(0, t));
  for (int t = 0; t < val_frames; ++t) {
    scene.val.push_back(frame(1, t));
    scene.val.push_back(frame(2, t));
  }
  scene.scale = 0.25;
  scene.center = {0.1, 0.2, 0.3};
  scene.near = 0.5;
  scene.far = 12.0;
  scene.fps = 24;
  return scene;
}

TEST(DyCheckDatasetTest, WrittenSceneReadsBackWithTheSameCameras) {
  testing::TempDir dir;
  const DyCheckScene scene = RandomScene(8, 3);
  WriteDyCheckMetadata(dir.path(), scene);
  ASSERT_TRUE(LooksLikeDyCheck(dir.path()));

  const Dataset full = LoadDataset(dir.path(), 1);
  EXPECT_EQ(full.kind, DatasetKind::kDyCheck);
  ASSERT_EQ(full.train.size(), 8u);
  ASSERT_EQ(full.val.size(), 6u);
  EXPECT_EQ(full.num_times, 8);
  EXPECT_DOUBLE_EQ(full.fps, 24);
  EXPECT_NEAR(*full.near, 0.5, 1e-12);
  EXPECT_NEAR(*full.far, 12.0, 1e-12);
  EXPECT_DOUBLE_EQ(full.scene_scale, 0.25);
  EXPECT_LT((full.scene_center - Eigen::Vector3d(0.1, 0.2, 0.3)).norm(), 1e-15);
  ASSERT_TRUE(full.up.has_value());
  for (std::size_t i = 0; i < scene.train.size(); ++i) {
    const PosedCamera& a = scene.train[i].camera;
    const PosedCamera& b = full.train[i].camera;
    EXPECT_EQ(full.train[i].id, DyCheckFrameId(0, static_cast<int>(i)));
    EXPECT_EQ(b.camera.params, a.camera.params);
    EXPECT_LT((a.cam_from_world.ToMatrix() - b.cam_from_world.ToMatrix())
                  .cwiseAbs()
                  .maxCoeff(),
              1e-9);
  }
  EXPECT_EQ(full.val[1].camera_id, 2);
  EXPECT_EQ(full.val[1].id, "2_00000");

  const Dataset half = LoadDataset(dir.path(), 2);
  EXPECT_EQ(half.train[0].camera.camera.width, 64);
  EXPECT_EQ(half.train[0].camera.camera.height, 48);
  EXPECT_DOUBLE_EQ(half.train[0].camera.camera.focal_x(), 110.25 / 2);
  EXPECT_EQ(half.train[0].rgb, dir / "rgb" / "2x" / "0_00000.png");

  const Json info = DatasetInfo(half);
  EXPECT_EQ(info["kind"], "dycheck");
  EXPECT_EQ(info["val"]["frames_per_camera"]["2"], 3);
  EXPECT_EQ(info["train"]["rgb_present"], 0);
  EXPECT_EQ(info["train"]["image_sizes"]["64x48"], 8);
}

TEST(DyCheckDatasetTest, MissingCameraAndBadSplitsNameTheFile) {
  testing::TempDir dir;
  WriteDyCheckMetadata(dir.path(), RandomScene(3, 1));
  std::filesystem::remove(dir / "camera" / "0_00001.json");
  try {
    LoadDataset(dir.path(), 1);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), (dir / "camera" / "0_00001.json").string());
  }
  WriteDyCheckMetadata(dir.path(), RandomScene(3, 1));
  WriteJson(dir / "splits" / "train.json", Json{{"frame_names", {"0_00000"}},
                                                {"camera_ids", {0, 0}},
                                                {"time_ids", {0}}});
  EXPECT_THROW(LoadDataset(dir.path(), 1), Error);
  WriteJson(
      dir / "splits" / "train.json",
      Json{{"frame_names", {"../x"}}, {"camera_ids", {0}}, {"time_ids", {0}}});
  EXPECT_THROW(LoadDataset(dir.path(), 1), Error);
  EXPECT_THROW(LoadDataset(dir.path(), 3), Error);

  // dataset.json and metadata.json must agree with the splits.
  WriteDyCheckMetadata(dir.path(), RandomScene(3, 1));
  Json index = ReadJson(dir / "dataset.json");
  index["train_ids"][1] = "0_00007";
  WriteJson(dir / "dataset.json", index);
  try {
    LoadDataset(dir.path(), 1);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "train_ids[1]");
  }
  WriteDyCheckMetadata(dir.path(), RandomScene(3, 1));
  Json metadata = ReadJson(dir / "metadata.json");
  metadata["1_00000"]["camera_id"] = 2;
  WriteJson(dir / "metadata.json", metadata);
  EXPECT_THROW(LoadDataset(dir.path(), 1), Error);
  EXPECT_THROW(LoadDataset(dir / "nowhere", 2), Error);
}

// One stray time id of 100000 would ask the motion model for 100001 poses:
// ids with gaps are numbered densely in their order, negative ones refused.
TEST(DyCheckDatasetTest, TimeIdsWithGapsAreNumberedDenselyNegativeRefused) {
  testing::TempDir dir;
  DyCheckScene scene = RandomScene(3, 1);
  scene.train[2].time_id = 100000;
  scene.val[0].time_id = scene.val[1].time_id = 1;
  WriteDyCheckMetadata(dir.path(), scene);
  const Dataset d = LoadDataset(dir.path(), 1);
  EXPECT_EQ(d.num_times, 3);
  EXPECT_EQ(d.train[2].time_id, 2);
  EXPECT_EQ(d.train[2].id, DyCheckFrameId(0, 100000));
  EXPECT_EQ(d.val[0].time_id, 1);

  WriteJson(dir / "splits" / "train.json",
            Json{{"frame_names", {"0_00000"}},
                 {"camera_ids", {0}},
                 {"time_ids", {-4}}});
  try {
    LoadDataset(dir.path(), 1);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "time_ids[0]");
    EXPECT_EQ(e.source(), (dir / "splits" / "train.json").string());
  }
}

}  // namespace
}  // namespace pano4d
