// Optional (label real-data): DyCheck's real paper-windmill metadata in
// ../shared/data. Without it the test is skipped with a loud message.
#include <gtest/gtest.h>

#include "src/datasets/dataset.h"

namespace pano4d {
namespace {

TEST(DyCheckRealDataTest, PaperWindmillCamerasAndSplits) {
  const char* env = std::getenv("PANO4D_DATA_DIR");
  const std::filesystem::path root =
      std::filesystem::path(env ? env : PANO4D_DATA_DIR) /
      "real/dycheck-paper-windmill-cameras";
  if (!std::filesystem::exists(root)) {
    GTEST_SKIP()
        << "REAL DATA MISSING: " << root
        << " not found; this real-data test did not run (set PANO4D_DATA_DIR)";
  }
  const Dataset dataset = LoadDataset(root, 2);
  ASSERT_EQ(dataset.train.size(), 277u);
  ASSERT_EQ(dataset.val.size(), 419u);
  for (const DatasetFrame& f : dataset.train) EXPECT_EQ(f.camera_id, 0);
  int camera1 = 0, camera2 = 0;
  for (const DatasetFrame& f : dataset.val) {
    camera1 += f.camera_id == 1;
    camera2 += f.camera_id == 2;
  }
  EXPECT_EQ(camera1, 219);
  EXPECT_EQ(camera2, 200);
  EXPECT_EQ(dataset.num_times, 277);
  EXPECT_DOUBLE_EQ(dataset.fps, 30.0);
  EXPECT_EQ(dataset.train[0].camera.camera.width, 360);  // 2x of 720x960
  EXPECT_EQ(dataset.train[0].camera.camera.height, 480);
  // The validation cameras look at the same scene from elsewhere: their
  // centres are well away from the training camera's.
  const double baseline =
      (dataset.val[0].camera.Center() - dataset.train[0].camera.Center())
          .norm();
  EXPECT_GT(baseline, 0.05);
}

}  // namespace
}  // namespace pano4d
