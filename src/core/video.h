#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "src/core/image.h"

namespace pano4d {

struct VideoInfo {
  int width = 0;
  int height = 0;
  double fps = 0.0;  // 0 when the container does not say
  std::int64_t frame_count =
      0;  // as the container reports it; may be an estimate
};

struct VideoReadOptions {
  int stride =
      1;  // keep every stride-th frame (frames 0, stride, 2 stride, ...)
  int max_frames = 0;  // stop after this many kept frames; 0 = no limit

  // Throws pano4d::Error naming the field ("stride" must be >= 1,
  // "max_frames" >= 0).
  void Check() const;
};

// Frames of a video file through OpenCV's VideoCapture (FFmpeg backend).
class VideoReader {
 public:
  // Throws pano4d::Error naming the path when it does not exist or OpenCV
  // cannot open it as a video.
  VideoReader(const std::filesystem::path& path, VideoReadOptions options = {});
  ~VideoReader();
  VideoReader(const VideoReader&) = delete;
  VideoReader& operator=(const VideoReader&) = delete;

  const VideoInfo& info() const { return info_; }

  // The next kept frame and its index in the source video; false at the end
  // of the video or once max_frames frames were returned.
  bool Next(Image* frame, std::int64_t* source_index = nullptr);

 private:
  std::filesystem::path path_;
  VideoReadOptions options_;
  VideoInfo info_;
  struct Capture;
  std::unique_ptr<Capture> capture_;
  std::int64_t next_index_ = 0;  // index of the next frame in the source
  int returned_ = 0;
};

// All kept frames at once (for short clips; use VideoReader to stream).
std::vector<Image> ReadVideoFrames(const std::filesystem::path& path,
                                   VideoReadOptions options = {});

}  // namespace pano4d
