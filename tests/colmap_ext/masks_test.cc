#include "colmap_ext/masks.h"

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/image.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;

TEST(DynamicMasksWriterTest, ColmapMasksAreInvertedAndNamedAfterTheImages) {
  testing::TempDir dir;
  cv::Mat a = cv::Mat::zeros(6, 8, CV_8UC1);
  a(cv::Rect(2, 1, 3, 2)).setTo(255);
  const cv::Mat b = cv::Mat::zeros(6, 8, CV_8UC1);
  const std::vector<std::string> names = {"0_00000.png", "cam1/abc.jpg"};
  WriteColmapMasks({a, b}, names, dir / "masks");
  WriteDynamicMasks({a, b}, names, dir / "dynamic");

  // COLMAP: images/abc.jpg -> masks/abc.jpg.png; 0 = no features there.
  ASSERT_TRUE(fs::exists(dir / "masks" / "0_00000.png.png"));
  ASSERT_TRUE(fs::exists(dir / "masks" / "cam1" / "abc.jpg.png"));
  const cv::Mat colmap = ReadMask(dir / "masks" / "0_00000.png.png");
  EXPECT_EQ(cv::countNonZero(colmap != (255 - a)), 0);
  EXPECT_EQ(cv::countNonZero(ReadMask(dir / "masks" / "cam1" / "abc.jpg.png")),
            6 * 8);
  const cv::Mat dynamic = ReadMask(dir / "dynamic" / "0_00000.png.png");
  EXPECT_EQ(cv::countNonZero(dynamic != a), 0);
  EXPECT_EQ(MaskPathFor(dir / "masks", "cam1/abc.jpg"),
            dir / "masks" / "cam1" / "abc.jpg.png");
  // No temporaries are left behind by the atomic writes.
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir.path())) {
    files += e.is_regular_file() ? 1 : 0;
  }
  EXPECT_EQ(files, 4);
}

TEST(DynamicMasksWriterTest, AnyNonzeroValueIsDynamic) {
  testing::TempDir dir;
  cv::Mat a = cv::Mat::zeros(4, 4, CV_8UC1);
  a.at<std::uint8_t>(1, 1) = 1;
  WriteColmapMasks({a}, {"a.png"}, dir.path());
  const cv::Mat colmap = ReadMask(dir / "a.png.png");
  EXPECT_EQ(colmap.at<std::uint8_t>(1, 1), 0);
  EXPECT_EQ(colmap.at<std::uint8_t>(0, 0), 255);
}

TEST(DynamicMasksWriterTest, MismatchesNameTheMask) {
  testing::TempDir dir;
  const cv::Mat a = cv::Mat::zeros(6, 8, CV_8UC1);
  const cv::Mat small = cv::Mat::zeros(3, 4, CV_8UC1);
  EXPECT_THROW(WriteColmapMasks({a, a}, {"a.png"}, dir.path()), Error);
  try {
    WriteColmapMasks({a, small}, {"a.png", "b.png"}, dir.path());
    FAIL() << "masks of different sizes were accepted";
  } catch (const Error& e) {
    EXPECT_NE(e.source().find("b.png"), std::string::npos) << e.what();
    EXPECT_EQ(e.field(), "size");
  }
  try {
    WriteDynamicMasks({cv::Mat(6, 8, CV_32FC1)}, {"a.png"}, dir.path());
    FAIL() << "a float mask was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "type");
  }
  EXPECT_THROW(WriteColmapMasks({a}, {"../a.png"}, dir.path()), Error);
  EXPECT_THROW(WriteColmapMasks({a}, {"/tmp/a.png"}, dir.path()), Error);
  // Nothing was written for the sets that failed their checks.
  EXPECT_FALSE(fs::exists(dir / "a.png.png"));
}

}  // namespace
}  // namespace pano4d
