#include "src/datasets/synth_render.h"

#include <algorithm>
#include <cmath>

#include "src/core/error.h"

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
                        const std::vector<TrainingView>& train, int stop_at) {
  const int height = val.depth.rows;
  const int width = val.depth.cols;
  const std::size_t num_parts =
      train.empty() ? 0 : train[0].poses.world_from_part.size();
  // Per view: every part's pose composed into the camera (camera_from_part)
  // as a matrix, and the pinhole intrinsics, so that one check is a 3x3
  // product and a division.
  struct View {
    std::vector<Eigen::Matrix3d> rotation;
    std::vector<Eigen::Vector3d> translation;
    double fx, fy, cx, cy;
    const cv::Mat* depth;
  };
  std::vector<View> views;
  views.reserve(train.size());
  for (const TrainingView& t : train) {
    const Camera& c = t.camera.camera;
    if (c.HasDistortion()) {
      throw Error("covisibility", "camera model", std::string(c.info().name),
                  "synthetic training cameras are pinhole");
    }
    View v{
        {},      {}, c.focal_x(), c.focal_y(), c.principal_x(), c.principal_y(),
        &t.depth};
    for (std::size_t p = 0; p < num_parts; ++p) {
      const Rigid3d camera_from_part =
          t.camera.cam_from_world * t.poses.world_from_part[p];
      v.rotation.push_back(camera_from_part.rotation.toRotationMatrix());
      v.translation.push_back(camera_from_part.translation);
    }
    views.push_back(std::move(v));
  }
  const int limit = stop_at > 0 ? stop_at : static_cast<int>(views.size());

  cv::Mat counts(height, width, CV_32SC1, cv::Scalar(0));
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      const int part = val.part[i];
      if (part < 0) continue;
      int seen = 0;
      for (std::size_t k = 0; k < views.size() && seen < limit; ++k) {
        // The same surface point at the training view's time, in its camera.
        const View& view = views[k];
        const Eigen::Vector3d cam =
            view.rotation[part] * val.local[i] + view.translation[part];
        if (!(cam.z() > kMinProjectDepth)) continue;
        const double u = view.fx * cam.x() / cam.z() + view.cx;
        const double v = view.fy * cam.y() / cam.z() + view.cy;
        if (!(u >= 0 && v >= 0 && u < view.depth->cols && v < view.depth->rows))
          continue;
        const double map =
            view.depth->at<float>(static_cast<int>(v), static_cast<int>(u));
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
