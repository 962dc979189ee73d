#include "src/core/video.h"

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "src/core/error.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

using testing::TempDir;

// An MJPEG AVI whose frame i is uniformly grey with level 10 i, so a decoded
// frame tells its own index.
std::filesystem::path WriteCountingVideo(const TempDir& dir, int frames) {
  const auto path = dir / "count.avi";
  cv::VideoWriter writer(path.string(),
                         cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0,
                         cv::Size(64, 48));
  EXPECT_TRUE(writer.isOpened());
  for (int i = 0; i < frames; ++i) {
    writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(10 * i)));
  }
  return path;
}

int IndexOf(const Image& frame) {
  return static_cast<int>(std::lround(cv::mean(frame.mat())[0] * 255 / 10));
}

TEST(VideoTest, StrideAndLimit) {
  TempDir dir;
  const auto path = WriteCountingVideo(dir, 20);
  VideoReader reader(path, {.stride = 3, .max_frames = 4});
  EXPECT_EQ(reader.info().width, 64);
  EXPECT_EQ(reader.info().height, 48);
  EXPECT_NEAR(reader.info().fps, 25.0, 1e-6);
  Image frame;
  std::int64_t index = -1;
  std::vector<std::int64_t> indices;
  while (reader.Next(&frame, &index)) {
    EXPECT_EQ(IndexOf(frame), index);
    EXPECT_EQ(frame.width(), 64);
    indices.push_back(index);
  }
  EXPECT_EQ(indices, (std::vector<std::int64_t>{0, 3, 6, 9}));
}

TEST(VideoTest, ReadsToTheEndWithoutALimit) {
  TempDir dir;
  const auto path = WriteCountingVideo(dir, 10);
  const std::vector<Image> frames = ReadVideoFrames(path, {.stride = 4});
  ASSERT_EQ(frames.size(), 3u);  // 0, 4, 8
  EXPECT_EQ(IndexOf(frames[2]), 8);
}

TEST(VideoTest, MissingAndUnreadableVideosNameThePath) {
  TempDir dir;
  try {
    VideoReader reader(dir / "nope.mp4");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              (dir / "nope.mp4").string() + ": does not exist");
  }
  testing::WriteText(dir / "fake.mp4", "not a video");
  try {
    VideoReader reader(dir / "fake.mp4");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open it as a video"),
              std::string::npos);
  }
}

TEST(VideoTest, OptionsAreChecked) {
  TempDir dir;
  const auto path = WriteCountingVideo(dir, 3);
  try {
    VideoReader reader(path, {.stride = 0});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "stride");
  }
  EXPECT_THROW(VideoReader(path, {.max_frames = -1}), Error);
}

}  // namespace
}  // namespace pano4d
