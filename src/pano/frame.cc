#include "src/pano/frame.h"

#include <cmath>
#include <string>

#include "src/core/error.h"

namespace pano4d {
namespace {

// Below this norm a levelled direction or mean up vector is treated as
// degenerate: its direction would be noise.
constexpr double kMinAxisNorm = 1e-6;

}  // namespace

EquirectProjection PanoramaFrame::Projection(int width, int height) const {
  EquirectProjection p;
  p.center = center;
  p.r_align = r_align;
  p.width = width;
  p.height = height;
  return p;
}

PanoramaFrame MakePanoramaFrame(const std::vector<Eigen::Vector3f>& points,
                                const std::vector<RasterCamera>& cameras) {
  if (points.empty()) {
    throw Error("panorama frame", "points", "0",
                "no points to place the panorama's centre at");
  }
  if (cameras.empty()) {
    throw Error("panorama frame", "cameras", "0",
                "no camera to align the panorama with");
  }
  PanoramaFrame frame;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) {
      throw Error("panorama frame", "points[" + std::to_string(i) + "]", "",
                  "is not finite");
    }
    sum += points[i].cast<double>();
  }
  frame.center = sum / static_cast<double>(points.size());

  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const RasterCamera& c : cameras)
    up -= c.rotation.row(1).transpose().cast<double>();  // world -y of camera
  if (!(up.norm() > kMinAxisNorm * cameras.size())) {
    throw Error("panorama frame", "cameras", std::to_string(cameras.size()),
                "their up vectors cancel out: no common up direction");
  }
  up.normalize();
  const Eigen::Vector3d view =
      cameras[0].rotation.row(2).transpose().cast<double>();
  Eigen::Vector3d x = view - view.dot(up) * up;
  if (!(x.norm() > kMinAxisNorm)) {
    throw Error("panorama frame", "cameras[0]", "",
                "looks straight along the up direction: the panorama's "
                "forward axis is undefined");
  }
  x.normalize();
  frame.r_align.col(0) = x;
  frame.r_align.col(1) = up.cross(x);
  frame.r_align.col(2) = up;
  return frame;
}

}  // namespace pano4d
