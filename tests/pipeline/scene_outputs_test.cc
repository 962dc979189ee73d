#include "src/pipeline/scene_outputs.h"

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;

// Frames of noise, which no encoder compresses much.
std::vector<cv::Mat> Frames(int width, int height, int count) {
  std::vector<cv::Mat> frames;
  cv::RNG rng(7);
  for (int i = 0; i < count; ++i) {
    frames.emplace_back(height, width, CV_8UC3);
    rng.fill(frames.back(), cv::RNG::UNIFORM, 0, 256);
  }
  return frames;
}

// The reason an MP4 is not written is the real one: frames too large for
// MPEG-4, a disk that fills, rather than "no FFmpeg backend?" for all.
TEST(WriteVideoTest, SaysWhyAVideoIsNotWritten) {
  testing::TempDir dir;
  std::vector<std::string> notes;
  ASSERT_TRUE(WriteVideo(dir / "small.mp4", Frames(64, 48, 3), 24, &notes))
      << (notes.empty() ? "" : notes.front());
  EXPECT_GT(fs::file_size(dir / "small.mp4"), 0u);
  EXPECT_TRUE(notes.empty());

  EXPECT_FALSE(WriteVideo(dir / "wide.mp4", Frames(kMaxMpeg4Side + 1, 16, 1),
                          24, &notes));
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("8192x16 are larger than MPEG-4 takes"),
            std::string::npos)
      << notes[0];
  EXPECT_FALSE(fs::exists(dir / "wide.mp4"));

  // A video larger than the disk it is written to.
  const std::vector<cv::Mat> noise = Frames(640, 480, 72);
  ASSERT_TRUE(WriteVideo(dir / "noise.mp4", noise, 24, &notes));
  notes.clear();
  constexpr int kDiskKib = 2048;
  ASSERT_GT(fs::file_size(dir / "noise.mp4"), 2 * kDiskKib * 1024u);
  testing::SmallDisk disk(kDiskKib);
  if (!disk.mounted()) {
    GTEST_SKIP() << "SMALL DISK UNAVAILABLE, a video on a full disk not "
                    "tested: "
                 << disk.why();
  }
  // A small video fits: the disk is not taken for full while it has room.
  notes.clear();
  EXPECT_TRUE(WriteVideo(disk / "fits.mp4", Frames(64, 48, 3), 24, &notes));
  EXPECT_TRUE(notes.empty()) << notes.front();
  EXPECT_FALSE(WriteVideo(disk / "full.mp4", noise, 24, &notes));
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("full"), std::string::npos) << notes[0];
  EXPECT_FALSE(fs::exists(disk / "full.mp4"));
}

}  // namespace
}  // namespace pano4d
