#include "src/core/video.h"

#include <cmath>
#include <cstdlib>

#include <opencv2/videoio.hpp>

#include "src/core/error.h"

namespace pano4d {

struct VideoReader::Capture {
  cv::VideoCapture capture;
};

namespace {

// Files are opened with FFmpeg only. With CAP_ANY, OpenCV also tries
// GStreamer and camera SDK backends on a file it cannot read, each printing
// its own warnings (and leaking in libusb); pano4d reports the failure in
// one line itself. For the same reason FFmpeg's log is quiet unless the user
// sets OPENCV_FFMPEG_LOGLEVEL (e.g. 32 for info) to debug a codec problem.
void QuietFfmpeg() {
  static const bool quiet = [] {
    return ::setenv("OPENCV_FFMPEG_LOGLEVEL", "-8", /*overwrite=*/0) ==
           0;  // AV_LOG_QUIET
  }();
  (void)quiet;
}

}  // namespace

void VideoReadOptions::Check() const {
  if (stride < 1)
    throw Error("video options", "stride", std::to_string(stride),
                "must be >= 1");
  if (max_frames < 0) {
    throw Error("video options", "max_frames", std::to_string(max_frames),
                "must be >= 0 (0 means no limit)");
  }
}

VideoReader::VideoReader(const std::filesystem::path& path,
                         VideoReadOptions options)
    : path_(path), options_(options), capture_(std::make_unique<Capture>()) {
  options_.Check();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw Error::In(path.string(), "does not exist");
  if (std::filesystem::is_directory(path, ec)) {
    throw Error::In(path.string(), "is a directory, expected a video file");
  }
  QuietFfmpeg();
  if (!capture_->capture.open(path.string(), cv::CAP_FFMPEG) ||
      !capture_->capture.isOpened()) {
    throw Error::In(
        path.string(),
        "OpenCV cannot open it as a video (corrupt file or unsupported codec; "
        "`ffprobe` tells which)");
  }
  cv::VideoCapture& cap = capture_->capture;
  info_.width = static_cast<int>(cap.get(cv::CAP_PROP_FRAME_WIDTH));
  info_.height = static_cast<int>(cap.get(cv::CAP_PROP_FRAME_HEIGHT));
  const double fps = cap.get(cv::CAP_PROP_FPS);
  info_.fps = std::isfinite(fps) && fps > 0 ? fps : 0.0;
  const double count = cap.get(cv::CAP_PROP_FRAME_COUNT);
  info_.frame_count =
      std::isfinite(count) && count > 0 ? static_cast<std::int64_t>(count) : 0;
}

VideoReader::~VideoReader() = default;

bool VideoReader::Next(Image* frame, std::int64_t* source_index) {
  if (options_.max_frames > 0 && returned_ >= options_.max_frames) return false;
  cv::VideoCapture& cap = capture_->capture;
  // Frames between kept ones are grabbed but not converted.
  while (next_index_ % options_.stride != 0) {
    if (!cap.grab()) return false;
    ++next_index_;
  }
  cv::Mat bgr;
  if (!cap.read(bgr) || bgr.empty()) return false;
  *frame = Image::FromOpenCV(
      bgr, path_.string() + " frame " + std::to_string(next_index_));
  if (source_index) *source_index = next_index_;
  ++next_index_;
  ++returned_;
  return true;
}

std::vector<Image> ReadVideoFrames(const std::filesystem::path& path,
                                   VideoReadOptions options) {
  VideoReader reader(path, options);
  std::vector<Image> frames;
  Image frame;
  while (reader.Next(&frame)) frames.push_back(frame);
  if (frames.empty())
    throw Error::In(path.string(), "contains no readable frames");
  return frames;
}

}  // namespace pano4d
