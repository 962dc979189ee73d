#include "src/datasets/nvidia_dataset.h"

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/npy.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

// An OpenCV camera-to-world rotation for a camera at `eye` looking at the
// origin, z up.
Eigen::Matrix3d WorldFromCam(const Eigen::Vector3d& eye) {
  const Eigen::Vector3d forward = (-eye).normalized();
  const Eigen::Vector3d right =
      forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Matrix3d m;
  m << right, forward.cross(right), forward;
  return m;
}

// Writes poses_bounds.npy in LLFF's [down, right, backwards] column order,
// the way NSFF's save_poses_nerf.py does.
std::vector<Eigen::Vector3d> WriteScene(const std::filesystem::path& dense,
                                        int n) {
  std::vector<double> values;
  std::vector<Eigen::Vector3d> eyes;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d eye(3 * std::cos(0.1 * i), -3 + 0.2 * i,
                              1.0 + 0.05 * i);
    eyes.push_back(eye);
    const Eigen::Matrix3d r = WorldFromCam(eye);
    for (int row = 0; row < 3; ++row) {
      values.insert(values.end(), {r(row, 1), r(row, 0), -r(row, 2), eye(row)});
      values.push_back(row == 0 ? 540.0 : row == 1 ? 960.0 : 800.0);  // h, w, f
    }
    values.insert(values.end(), {1.0 + i, 10.0 + i});
  }
  WriteNpy(dense / "poses_bounds.npy", NpyArray::FromDoubles({n, 17}, values));
  return eyes;
}

TEST(NvidiaDatasetTest, LlffPosesBecomeOpenCvCamerasAndTheMonocularProtocol) {
  testing::TempDir dir;
  const auto dense = dir / "dense";
  const std::vector<Eigen::Vector3d> eyes = WriteScene(dense, 12);
  for (int i = 0; i < 12; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "%03d.png", i);
    WriteImage(dense / "images_2" / name, Image(480, 270));
  }
  WriteImage(dense / "mv_images" / "00003" / "cam01.jpg", Image(480, 270));

  ASSERT_TRUE(LooksLikeNvidia(dir.path()));
  const Dataset d = LoadDataset(dir.path(), 2);
  EXPECT_EQ(d.kind, DatasetKind::kNvidia);
  ASSERT_EQ(d.train.size(), 12u);
  ASSERT_EQ(d.val.size(), 12u);
  EXPECT_DOUBLE_EQ(*d.near, 1.0);
  EXPECT_DOUBLE_EQ(*d.far, 21.0);
  for (int i = 0; i < 12; ++i) {
    const DatasetFrame& f = d.train[i];
    EXPECT_EQ(f.camera_id, i);
    EXPECT_EQ(f.time_id, i);
    EXPECT_EQ(f.camera.camera.width, 480);
    EXPECT_DOUBLE_EQ(f.camera.camera.focal_x(), 400.0);  // 800 at 960 px wide
    EXPECT_LT((f.camera.Center() - eyes[i]).norm(), 1e-12);
    // Every camera looks at the origin: it lands on the principal point.
    EXPECT_LT(
        (*f.camera.Project(Eigen::Vector3d::Zero()) - Eigen::Vector2d(240, 135))
            .norm(),
        1e-9);
    // A point above the origin appears above it (OpenCV y down).
    EXPECT_LT(f.camera.Project(Eigen::Vector3d(0, 0, 0.5))->y(), 135);
    // View 0 tests at every time.
    EXPECT_EQ(d.val[i].camera_id, 0);
    EXPECT_EQ(d.val[i].time_id, i);
    EXPECT_LT((d.val[i].camera.Center() - eyes[0]).norm(), 1e-12);
  }
  EXPECT_EQ(d.val[3].rgb, dense / "mv_images" / "00003" / "cam01.jpg");
  EXPECT_EQ(d.val[4].rgb, dense / "gt" / "v000_t004.png");
  // The scene is the folder holding dense/; the report names the protocol.
  EXPECT_EQ(d.scene, dir.path().filename().string());
  EXPECT_EQ(SplitDescription(d),
            "train: cameras 0..11, 12 frames; val: camera 0, 12 frames; "
            "480x270 (factor 2)");
  EXPECT_EQ(LoadDataset(dir.path()).factor, 2);  // the protocol's
}

TEST(NvidiaDatasetTest, WithoutImagesSizesComeFromHwf) {
  testing::TempDir dir;
  WriteScene(dir.path(), 3);
  const Dataset d = LoadDataset(dir.path(), 2);
  EXPECT_EQ(d.train[0].camera.camera.width, 480);
  EXPECT_EQ(d.train[0].camera.camera.height, 270);
}

TEST(NvidiaDatasetTest, RejectsMalformedPoses) {
  testing::TempDir dir;
  WriteNpy(dir / "poses_bounds.npy",
           NpyArray::FromDoubles({2, 16}, std::vector<double>(32, 1.0)));
  EXPECT_THROW(LoadDataset(dir.path(), 1), Error);
  std::vector<double> not_rotation(34, 0.5);
  WriteNpy(dir / "poses_bounds.npy",
           NpyArray::FromDoubles({2, 17}, not_rotation));
  try {
    LoadDataset(dir.path(), 1);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "row 0");
  }
  WriteScene(dir.path(), 4);
  WriteImage(dir / "images" / "000.png",
             Image(960, 540));  // 1 image for 4 poses
  EXPECT_THROW(LoadDataset(dir.path(), 1), Error);
}

}  // namespace
}  // namespace pano4d
