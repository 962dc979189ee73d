#include "src/datasets/depth_map.h"

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "src/core/error.h"
#include "src/core/log.h"
#include "src/core/npy.h"
#include "src/core/strings.h"

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
  std::int64_t beyond = 0;
  for (float& d : cv::Mat_<float>(m)) {
    if (d > kMaxPlausibleDepth) ++beyond;
    if (!std::isfinite(d) || d < 0 || d > kMaxPlausibleDepth) d = 0;
  }
  if (beyond > 0) {
    PANO4D_LOG(kWarning) << path.string() << ": " << beyond << " pixels beyond "
                         << kMaxPlausibleDepth
                         << " scene units taken as no depth (a renderer's "
                            "background, or a broken conversion?)";
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
    throw Error(frame.depth.string(), "size", SizeText(depth.cols, depth.rows),
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
