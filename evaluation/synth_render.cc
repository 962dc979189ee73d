#include "evaluation/synth_render.h"

#include <algorithm>
#include <cmath>

namespace pano4d::synth {

RenderedFrame RenderFrame(const Scene& scene, const PosedCamera& camera,
                          double s, bool shade, bool keep_surface) {
  const int width = camera.camera.width;
  const int height = camera.camera.height;
  const PartPoses poses = PosesAt(scene, s);
  const Eigen::Vector3d origin = camera.Center();
  const Eigen::Quaterniond world_from_cam =
      camera.cam_from_world.rotation.conjugate();

  RenderedFrame frame;
  if (shade) frame.rgb = Image(width, height);
  frame.depth = cv::Mat(height, width, CV_32FC1, cv::Scalar(0));
  frame.instance = cv::Mat(height, width, CV_8UC1, cv::Scalar(0));
  frame.dynamic = cv::Mat(height, width, CV_8UC1, cv::Scalar(0));
  if (keep_surface) {
    frame.part.assign(static_cast<std::size_t>(width) * height, -1);
    frame.local.assign(static_cast<std::size_t>(width) * height,
                       Eigen::Vector3d::Zero());
  }

  // Rows are independent, so the result does not depend on the thread count.
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const UnprojectResult ray = camera.camera.Unproject({x + 0.5, y + 0.5});
      if (!ray.ok()) continue;
      const Hit hit = Intersect(scene, poses, origin, world_from_cam * ray.ray);
      if (!hit.valid()) continue;
      const Part& part = scene.parts[hit.part];
      frame.depth.at<float>(y, x) =
          static_cast<float>(hit.distance * ray.ray.z());
      frame.instance.at<std::uint8_t>(y, x) =
          static_cast<std::uint8_t>(part.instance);
      frame.dynamic.at<std::uint8_t>(y, x) = part.dynamic ? 255 : 0;
      if (shade) {
        const Eigen::Vector3d color = Shade(scene, hit);
        frame.rgb.at(x, y) = cv::Vec3f(static_cast<float>(color.x()),
                                       static_cast<float>(color.y()),
                                       static_cast<float>(color.z()));
      }
      if (keep_surface) {
        const std::size_t i = static_cast<std::size_t>(y) * width + x;
        frame.part[i] = hit.part;
        frame.local[i] = hit.local;
      }
    }
  }
  return frame;
}

int CovisibilityThreshold(int num_training_views) {
  return std::max(5, static_cast<int>(0.1 * num_training_views));
}

cv::Mat CovisibleCounts(const RenderedFrame& val,
                        const std::vector<TrainingView>& train) {
  const int height = val.depth.rows;
  const int width = val.depth.cols;
  cv::Mat counts(height, width, CV_32SC1, cv::Scalar(0));
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      const int part = val.part[i];
      if (part < 0) continue;
      int seen = 0;
      for (const TrainingView& view : train) {
        // The same surface point at the training view's time.
        const Eigen::Vector3d world =
            view.poses.world_from_part[part] * val.local[i];
        const Eigen::Vector3d cam = view.camera.cam_from_world * world;
        const std::optional<Eigen::Vector2d> pixel =
            view.camera.camera.Project(cam);
        if (!pixel) continue;
        const int u = static_cast<int>(std::floor(pixel->x()));
        const int v = static_cast<int>(std::floor(pixel->y()));
        if (u < 0 || v < 0 || u >= view.depth.cols || v >= view.depth.rows)
          continue;
        const double map = view.depth.at<float>(v, u);
        if (map > 0 && cam.z() <= map * (1 + kCovisibleRelativeDepth) +
                                      kCovisibleAbsoluteDepth) {
          ++seen;
        }
      }
      counts.at<int>(y, x) = seen;
    }
  }
  return counts;
}

cv::Mat CovisibleMask(const cv::Mat& counts, int num_training_views) {
  const int threshold = CovisibilityThreshold(num_training_views);
  cv::Mat mask = counts > threshold;  // 255 where true
  return mask;
}

}  // namespace pano4d::synth
