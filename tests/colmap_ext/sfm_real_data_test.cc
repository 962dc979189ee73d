// `pano4d sfm` on the real photos in ../shared/data/real (label real-data;
// says REAL DATA MISSING or COLMAP MISSING and skips when its input is
// absent). The real video's SfM is checked by FitRealDataTest, whose `run`
// goes through it: a second SfM of the same video would add minutes to CI.
#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>

#include "colmap_ext/colmap_runner.h"
#include "colmap_ext/model.h"
#include "colmap_ext/sfm.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

namespace fs = std::filesystem;

const fs::path kReal = fs::path(PANO4D_DATA_DIR) / "real";

#define PANO4D_REQUIRE(path)                                 \
  if (!FindOnPath("colmap"))                                 \
    GTEST_SKIP() << "COLMAP MISSING: colmap is not on PATH"; \
  if (!fs::exists(path))                                     \
  GTEST_SKIP() << "REAL DATA MISSING: " << (path)            \
               << " (set PANO4D_DATA_DIR to the folder of real captures)"

// 11 photos of a building with known intrinsics (K.txt: f = 2905.88 px at
// 2832 x 2128), downscaled to 1000 px as the issue asks.
TEST(SfmRealDataTest, SceauxCastleRegistersAllImagesWithTheRightFocal) {
  const fs::path images = kReal / "sceaux-castle";
  PANO4D_REQUIRE(images);
  testing::TempDir dir;
  SfmOptions options;
  options.images = images;
  options.workspace = dir / "ws";
  options.max_size = 1000;
  options.matcher = "exhaustive";
  options.dynamic_masks = false;  // still photos: nothing moves
  const SfmReport report = RunSfm(options);
  const ColmapModel model = ReadModel(options.workspace / "sparse" / "0");
  ASSERT_EQ(model.cameras.size(), 1u);
  const double expected = 2905.88 * 1000.0 / 2832.0;
  const double focal = model.cameras[0].params[0];
  std::printf(
      "sceaux-castle: %d of %d registered, %d points, %.3f px; focal %.1f "
      "against K.txt scaled %.1f (%.2f%%)\n",
      report.registered, report.frames, report.points3D,
      report.mean_reprojection_error, focal, expected,
      100 * (focal - expected) / expected);
  EXPECT_EQ(report.frames, 11);
  EXPECT_EQ(report.registered, 11);
  EXPECT_NEAR(focal, expected, 0.03 * expected);
}

}  // namespace
}  // namespace pano4d
