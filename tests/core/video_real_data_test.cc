// Optional: decodes the real lady-running clip in ../shared/data (label
// real-data). Without the data the tests are skipped with a loud message.
#include <filesystem>

#include <gtest/gtest.h>

#include "src/core/image.h"
#include "src/core/video.h"

namespace pano4d {
namespace {

std::filesystem::path DataDir() {
  const char* env = std::getenv("PANO4D_DATA_DIR");
  return env ? std::filesystem::path(env)
             : std::filesystem::path(PANO4D_DATA_DIR);
}

#define REQUIRE_REAL_DATA(relative)                                     \
  const std::filesystem::path data_path = DataDir() / (relative);       \
  if (!std::filesystem::exists(data_path)) {                            \
    GTEST_SKIP() << "REAL DATA MISSING: " << data_path                  \
                 << " not found; this real-data test did not run (set " \
                    "PANO4D_DATA_DIR)";                                 \
  }

TEST(VideoRealDataTest, LadyRunningDecodesWithStrideAndLimit) {
  REQUIRE_REAL_DATA("real/lady-running.mp4");
  VideoReader reader(data_path, {.stride = 8, .max_frames = 5});
  EXPECT_EQ(reader.info().width, 854);
  EXPECT_EQ(reader.info().height, 480);
  Image frame;
  std::int64_t index = 0;
  int count = 0;
  while (reader.Next(&frame, &index)) {
    EXPECT_EQ(index, 8 * count);
    EXPECT_TRUE(frame.AllFinite());
    ++count;
  }
  EXPECT_EQ(count, 5);
}

TEST(VideoRealDataTest, FirstFrameMatchesTheShippedJpeg) {
  REQUIRE_REAL_DATA("real/lady-running.mp4");
  const std::vector<Image> frames =
      ReadVideoFrames(data_path, {.max_frames = 1});
  const Image jpeg = ReadImage(DataDir() / "real/lady-running/00000.jpg");
  ASSERT_EQ(frames[0].width(), jpeg.width());
  ASSERT_EQ(frames[0].height(), jpeg.height());
  // Two lossy encodings of the same frame: close on average, not equal.
  cv::Mat diff;
  cv::absdiff(frames[0].mat(), jpeg.mat(), diff);
  EXPECT_LT(cv::mean(diff)[0], 0.05);
}

}  // namespace
}  // namespace pano4d
