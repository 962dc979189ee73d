#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "src/core/image.h"
#include "src/core/posed_camera.h"
#include "src/datasets/synth_scene.h"

namespace pano4d::synth {

// One ray per pixel, through the pixel centre (COLMAP's +0.5 convention),
// so the depth of pixel (i, j) is exactly the z of the surface point that
// Unproject(i + 0.5, j + 0.5) * depth gives.
struct RenderedFrame {
  Image rgb;         // empty unless shaded
  cv::Mat depth;     // CV_32FC1 z-depth in metres, 0 where no surface
  cv::Mat instance;  // CV_8UC1 instance id, 0 where no surface
  cv::Mat dynamic;   // CV_8UC1 255 on moving objects
  // Per pixel (row-major), when asked for: the part hit (-1 none) and the
  // point in that part's frame, to follow the surface point over time.
  std::vector<int> part;
  std::vector<Eigen::Vector3d> local;
};

RenderedFrame RenderFrame(const Scene& scene, const PosedCamera& camera,
                          double s, bool shade, bool keep_surface);

// A training view as covisibility sees it: camera, part poses at its time,
// and its depth map (at the camera's resolution).
struct TrainingView {
  PosedCamera camera;
  PartPoses poses;
  cv::Mat depth;
};

// DyCheck's rule (tools/process_covisible.py): a validation pixel is
// covisible when its surface point is seen, unoccluded, in more than
// max(5, floor(0.1 * S)) of the S training views.
int CovisibilityThreshold(int num_training_views);

// How far a transported point may lie behind the training depth map and
// still count as seen: the map holds the depth at pixel centres, the point
// lies anywhere in the pixel, so on slanted surfaces the two differ by the
// depth gradient across a pixel. Surfaces that occlude one another in these
// scenes are tens of centimetres apart.
inline constexpr double kCovisibleRelativeDepth = 0.03;
inline constexpr double kCovisibleAbsoluteDepth = 0.005;  // metres

// Visible-view counts per pixel (CV_32SC1) of a validation frame rendered
// with keep_surface, and the covisible mask (CV_8UC1, 255 = covisible).
// Counting stops at `stop_at` views (the mask only needs to know whether a
// count exceeds the threshold); 0 counts every view. Training cameras must
// be pinhole, as the synthetic ones are.
cv::Mat CovisibleCounts(const RenderedFrame& val,
                        const std::vector<TrainingView>& train,
                        int stop_at = 0);
cv::Mat CovisibleMask(const cv::Mat& counts, int num_training_views);

}  // namespace pano4d::synth
