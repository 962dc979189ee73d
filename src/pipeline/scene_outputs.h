#pragma once
// What `render`, `export` and the report share: the fitted scene of a
// workspace, rendering it to 8-bit images, and MP4 videos.

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "src/core/frames.h"
#include "src/core/workspace.h"
#include "src/gs/scene.h"
#include "src/pano/trajectory.h"
#include "src/render/rasterizer.h"

namespace pano4d {

struct FittedWorkspace {
  WorkspaceFrames frames;
  GaussianScene scene;
  // The expansion's cameras (trajectories.json); empty when none ran.
  std::vector<ExpandedView> expanded;
  // The training frame nearest the middle time: the reference of the
  // novel-view paths.
  const WorkspaceFrame& MiddleFrame() const;
  // The panorama frame's centre (the centroid of the Gaussians).
  Eigen::Vector3d Center() const;
};

// frames.json, the checkpoint of `pano4d fit` and its expanded cameras;
// throws pano4d::Error
// naming the missing file and the command that makes it.
FittedWorkspace LoadFittedWorkspace(const Workspace& workspace);

// Renders the scene posed at `time` (checked against its times) as BGR8.
class SceneRenderer {
 public:
  explicit SceneRenderer(const GaussianScene& scene) : scene_(scene) {}
  cv::Mat Render(const RasterCamera& camera, int time);
  // The last Render's output (linear RGB, z-depth, alpha) before it became
  // 8-bit.
  const RenderOutput& output() const { return out_; }

 private:
  const GaussianScene& scene_;
  Rasterizer rasterizer_;
  GaussianModel posed_;
  int posed_time_ = -1;
  RenderOutput out_;
};

// The largest side MPEG-4 part 2 (mp4v) encodes: FFmpeg refuses 8192.
inline constexpr int kMaxMpeg4Side = 8191;

// An MP4 (OpenCV's FFmpeg backend, mp4v) written under a temporary name and
// renamed when complete. Frames larger than kMaxMpeg4Side, a backend that
// does not open, or a disk that fills: returns false and adds a note that
// says which.
bool WriteVideo(const std::filesystem::path& path,
                const std::vector<cv::Mat>& frames, double fps,
                std::vector<std::string>* notes);

}  // namespace pano4d
