#include "src/datasets/depth_map.h"

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "src/core/error.h"
#include "src/core/npy.h"

namespace pano4d {
namespace fs = std::filesystem;

cv::Mat ReadDepthMap(const fs::path& path) {
  cv::Mat m;
  if (path.extension() == ".npy") {
    const NpyArray a = ReadNpy(path);
    if (a.shape.size() < 2 || (a.shape.size() == 3 && a.shape[2] != 1) ||
        a.shape.size() > 3) {
      throw Error(path.string(), "shape", std::to_string(a.shape.size()) + "-d",
                  "expected H x W or H x W x 1");
    }
    const std::vector<float> v = a.ToFloats();
    m.create(static_cast<int>(a.shape[0]), static_cast<int>(a.shape[1]),
             CV_32F);
    std::copy(v.begin(), v.end(), m.ptr<float>());
  } else {
    const cv::Mat raw = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    if (raw.empty() || raw.channels() != 1) {
      throw Error(path.string(), "", "",
                  "not a single-channel depth image (use .npy, 16-bit PNG in "
                  "millimetres, or float TIFF/EXR)");
    }
    raw.convertTo(m, CV_32F, raw.depth() == CV_16U ? 1e-3 : 1.0);
  }
  m.forEach<float>([](float& d, const int*) {
    if (!std::isfinite(d) || d < 0) d = 0;
  });
  double largest = 0;
  cv::minMaxLoc(m, nullptr, &largest);
  if (largest > kMaxPlausibleDepth) {
    throw Error(path.string(), "depth", std::to_string(largest),
                "beyond any scene: expected z-depth in the scene's units "
                "(metres, or a dataset's own), 0 where none");
  }
  return m;
}

void RayDistanceToZ(const Camera& camera, cv::Mat* depth) {
  const double fx = camera.focal_x(), fy = camera.focal_y();
  const double cx = camera.principal_x(), cy = camera.principal_y();
  for (int y = 0; y < depth->rows; ++y) {
    for (int x = 0; x < depth->cols; ++x) {
      const double xn = (x + 0.5 - cx) / fx, yn = (y + 0.5 - cy) / fy;
      depth->at<float>(y, x) = static_cast<float>(
          depth->at<float>(y, x) / std::sqrt(xn * xn + yn * yn + 1.0));
    }
  }
}

cv::Mat ReadDepth(const DatasetFrame& frame) {
  cv::Mat depth = ReadDepthMap(frame.depth);
  const Camera& c = frame.camera.camera;
  if (depth.cols != c.width || depth.rows != c.height) {
    throw Error(frame.depth.string(), "size",
                std::to_string(depth.cols) + "x" + std::to_string(depth.rows),
                "differs from its frame's camera");
  }
  if (frame.depth_convention == DepthConvention::kRayDistance)
    RayDistanceToZ(c, &depth);
  return depth;
}

void WriteDepthMap(const fs::path& path, const cv::Mat& depth) {
  std::vector<float> v(depth.begin<float>(), depth.end<float>());
  WriteNpy(path, NpyArray::FromFloats({depth.rows, depth.cols}, v));
}

}  // namespace pano4d
