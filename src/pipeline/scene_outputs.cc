#include "src/pipeline/scene_outputs.h"

#include <cmath>
#include <limits>

#include <opencv2/videoio.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/gs/checkpoint.h"
#include "src/pano/frame.h"
#include "src/pano/trajectory_io.h"

namespace pano4d {
namespace fs = std::filesystem;

const WorkspaceFrame& FittedWorkspace::MiddleFrame() const {
  const WorkspaceFrame* best = &frames.train.front();
  for (const WorkspaceFrame& f : frames.train)
    if (std::abs(f.time - frames.num_times / 2) <
        std::abs(best->time - frames.num_times / 2))
      best = &f;
  return *best;
}

Eigen::Vector3d FittedWorkspace::Center() const {
  GaussianModel posed;
  scene.ComposeAt(scene.canonical_time, &posed);
  std::vector<Eigen::Vector3f> means(posed.size());
  for (std::size_t i = 0; i < posed.size(); ++i)
    means[i] = Eigen::Vector3f::Map(&posed.means[i * 3]);
  std::vector<RasterCamera> cameras;
  for (const WorkspaceFrame& f : frames.train)
    cameras.push_back(RasterCamera::FromPosed(f.camera));
  return MakePanoramaFrame(means, cameras).center;
}

FittedWorkspace LoadFittedWorkspace(const Workspace& ws) {
  FittedWorkspace w;
  w.frames = ReadWorkspaceFrames(ws.root());
  const fs::path ckpt = ws.checkpoint();
  if (!fs::exists(ckpt) && fs::exists(ws.previous_fit())) {
    throw Error::In(ckpt.string(),
                    "missing: a `pano4d fit --force` started over and has not "
                    "completed (stopped, or still running); the fit before it "
                    "is in " +
                        ws.previous_fit().string() +
                        ": let the new fit complete (`pano4d fit --resume`), "
                        "or move that folder's contents back");
  }
  if (!fs::exists(ckpt)) {
    throw Error(ckpt.string(), "", "",
                "missing; run `pano4d fit --workspace " + ws.root().string() +
                    "` (or `pano4d run`) first");
  }
  w.scene = ReadCheckpointScene(ckpt);
  if (w.frames.train.empty()) {
    throw Error(ws.frames_json().string(), "train", "", "no training frames");
  }
  if (fs::exists(ws.trajectories_json()))
    w.expanded = ReadTrajectories(ws.trajectories_json());
  return w;
}

cv::Mat SceneRenderer::Render(const RasterCamera& camera, int time) {
  if (time < 0 || time >= scene_.num_times) {
    throw Error("render", "time", std::to_string(time),
                "must be in [0, " + std::to_string(scene_.num_times) +
                    "), the fitted scene's times");
  }
  if (time != posed_time_) {
    scene_.ComposeAt(time, &posed_);
    posed_time_ = time;
  }
  rasterizer_.Render(posed_, camera, RasterSettings{}, &out_);
  cv::Mat rgb(out_.height, out_.width, CV_32FC3);
  std::copy(out_.rgb.begin(), out_.rgb.end(), rgb.ptr<float>());
  for (float v : out_.rgb) {
    if (!std::isfinite(v)) {
      throw Error("render", "pixel", std::to_string(v),
                  "not finite: the checkpoint holds a broken Gaussian");
    }
  }
  return Image::FromRgb32f(rgb).ToBgr8();
}

bool WriteVideo(const fs::path& path, const std::vector<cv::Mat>& frames,
                double fps, std::vector<std::string>* notes) {
  if (frames.empty()) return false;
  const cv::Size size = frames.front().size();
  if (size.width > kMaxMpeg4Side || size.height > kMaxMpeg4Side) {
    notes->push_back(
        path.filename().string() + ": frames of " + std::to_string(size.width) +
        "x" + std::to_string(size.height) + " are larger than MPEG-4 takes (" +
        std::to_string(kMaxMpeg4Side) +
        " a side); the PNG frames have the same views");
    return false;
  }
  // OpenCV picks the container from the extension, so the temporary name
  // keeps it.
  const fs::path partial =
      path.parent_path() / (path.stem().string() + ".partial.mp4");
  cv::VideoWriter writer(
      partial.string(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps, size);
  // OpenCV reports neither why it could not open a writer nor a failed
  // write: a disk with almost no room left is the likely cause to name.
  if (!writer.isOpened()) {
    notes->push_back(path.filename().string() +
                     (DiskIsFull(path)
                          ? ": the disk holding it is full"
                          : ": OpenCV could not open an MP4 writer (no "
                            "FFmpeg backend?)") +
                     "; the PNG frames have the same views");
    return false;
  }
  for (const cv::Mat& f : frames) writer.write(f);
  writer.release();
  std::error_code ec;
  if (DiskIsFull(path) || !fs::exists(partial, ec) ||
      fs::file_size(partial, ec) == 0) {
    fs::remove(partial, ec);
    notes->push_back(path.filename().string() +
                     ": not written in full (the disk holding it is full?); "
                     "the PNG frames have the same views");
    return false;
  }
  fs::rename(partial, path);
  return true;
}

}  // namespace pano4d
