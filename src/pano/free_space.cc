#include "src/pano/free_space.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

void CheckSize(const cv::Mat& m, int type, const RasterCamera& camera,
               const char* field) {
  if (m.type() != type || m.cols != camera.width || m.rows != camera.height) {
    throw Error("seen depth", field, SizeText(m.cols, m.rows),
                std::string("expected one ") +
                    (type == CV_32FC1 ? "float" : "byte") +
                    " per pixel of its " +
                    SizeText(camera.width, camera.height) + " camera");
  }
}

}  // namespace

SeenDepth MakeSeenDepth(const RasterCamera& camera, const cv::Mat& depth,
                        const cv::Mat& guessed) {
  CheckSize(depth, CV_32FC1, camera, "depth");
  const cv::Mat box = cv::Mat::ones(3, 3, CV_8U);
  // Unknown becomes 0 and, through the minimum, spreads to the neighbours:
  // nothing is claimed next to where nothing was seen.
  cv::Mat known = depth.clone();
  known.forEach<float>([](float& d, const int*) {
    if (!(d > 0) || !std::isfinite(d)) d = 0;
  });
  SeenDepth seen{camera, cv::Mat(), cv::Mat()};
  cv::erode(known, seen.depth, box, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  if (!guessed.empty()) {
    CheckSize(guessed, CV_8UC1, camera, "guessed");
    cv::erode(guessed == 0, seen.observed, box, cv::Point(-1, -1), 1,
              cv::BORDER_REPLICATE);
    seen.observed /= 255;
  }
  return seen;
}

float CameraClearance(const cv::Mat& depth) {
  std::vector<float> valid;
  for (int y = 0; y < depth.rows; ++y) {
    const float* row = depth.ptr<float>(y);
    for (int x = 0; x < depth.cols; ++x)
      if (row[x] > 0 && std::isfinite(row[x])) valid.push_back(row[x]);
  }
  if (valid.empty()) return 0.0f;
  const auto nth =
      valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 50);
  std::nth_element(valid.begin(), nth, valid.end());
  return kCameraClearance * *nth;
}

Sight LookFrom(const SeenDepth& view, const Eigen::Vector3f& point,
               bool* observed) {
  const RasterCamera& c = view.camera;
  const Eigen::Vector3f p = c.rotation * point + c.translation;
  if (!(p.z() > 0)) return Sight::kUnseen;
  const float u = c.fx * p.x() / p.z() + c.cx;
  const float w = c.fy * p.y() / p.z() + c.cy;
  if (!(u >= 0 && w >= 0 && u < c.width && w < c.height)) return Sight::kUnseen;
  const int x = static_cast<int>(u), y = static_cast<int>(w);
  const float seen = view.depth.at<float>(y, x);
  if (!(seen > 0)) return Sight::kUnknown;
  if (observed)
    *observed = view.observed.empty() || view.observed.at<std::uint8_t>(y, x);
  if (p.z() < seen * (1 - kFreeSpaceTolerance)) return Sight::kSeenThrough;
  if (p.z() <= seen * (1 + kFreeSpaceTolerance)) return Sight::kOnSurface;
  return Sight::kUnseen;
}

Sight Look(const std::vector<SeenDepth>& views, const Eigen::Vector3f& point) {
  Sight sight = Sight::kUnseen;  // the enumerators rise in precedence
  for (const SeenDepth& v : views) {
    const Sight s = LookFrom(v, point);
    if (s == Sight::kSeenThrough) return s;
    sight = std::max(sight, s);
  }
  return sight;
}

std::vector<std::uint8_t> InFreeSpace(const std::vector<SeenDepth>& frames,
                                      const std::vector<SeenDepth>& expanded,
                                      const float* xyz, std::size_t count,
                                      const Layout* planes,
                                      float plane_tolerance) {
  std::vector<std::uint8_t> empty(count, 0);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < static_cast<std::int64_t>(count); ++i) {
    const Eigen::Vector3f p(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    const Sight by_frames = Look(frames, p);
    if (by_frames == Sight::kSeenThrough || by_frames == Sight::kOnSurface) {
      empty[i] = by_frames == Sight::kSeenThrough;
      continue;
    }
    if (planes && planes->PlaneFaceAt(p, plane_tolerance)) continue;
    const bool by_a_camera =
        std::any_of(frames.begin(), frames.end(), [&](const SeenDepth& f) {
          return f.clearance > 0 &&
                 (p - f.camera.Center()).norm() < f.clearance;
        });
    if (by_a_camera || by_frames == Sight::kUnknown) {
      empty[i] = by_a_camera;
      continue;
    }
    bool warp_saw_through = false;
    int through = 0, on = 0;
    for (const SeenDepth& v : expanded) {
      bool observed = false;
      const Sight s = LookFrom(v, p, &observed);
      if (s == Sight::kSeenThrough && observed) {
        warp_saw_through = true;
        break;
      }
      through += s == Sight::kSeenThrough;
      on += s == Sight::kOnSurface;
    }
    empty[i] = warp_saw_through || through > kFreeSpaceVotes * on;
  }
  return empty;
}

}  // namespace pano4d
