#include "src/pano/warp.h"

#include <cmath>
#include <limits>
#include <string>

#include "src/core/error.h"

namespace pano4d {
namespace {

void CheckInput(const cv::Mat& rgb, const cv::Mat& depth,
                const RasterCamera& source, const cv::Mat& valid) {
  const auto size = [](const cv::Mat& m) {
    return std::to_string(m.cols) + "x" + std::to_string(m.rows);
  };
  const std::string expected =
      std::to_string(source.width) + "x" + std::to_string(source.height);
  if (rgb.type() != CV_32FC3 || rgb.cols != source.width ||
      rgb.rows != source.height) {
    throw Error(
        "warp", "rgb", size(rgb),
        "expected a CV_32FC3 image of the source camera's size " + expected);
  }
  if (depth.type() != CV_32FC1 || depth.size() != rgb.size()) {
    throw Error(
        "warp", "depth", size(depth),
        "expected a CV_32FC1 map of the source camera's size " + expected);
  }
  if (!valid.empty() &&
      (valid.type() != CV_8UC1 || valid.size() != rgb.size())) {
    throw Error(
        "warp", "valid", size(valid),
        "expected a CV_8UC1 mask of the source camera's size " + expected);
  }
}

// One source pixel's landing: target position (continuous, pixel centres at
// +0.5) and depth. False when it lands behind the target camera.
struct Landing {
  float u, v, z;
};

// Splatting leaves cracks where the target magnifies the source (a surface
// seen closer or more frontally): gaps of a pixel or two between the
// landings of one surface. A hole pixel with covered pixels on both sides,
// within kWarpMaxCrack along a row, column or diagonal, at depths that
// agree, is such a crack and takes the values interpolated between them
// (the front-most pair when several qualify). Holes between different
// surfaces (disocclusions) stay holes.
void FillCracks(WarpResult* w) {
  const int h = w->mask.rows, wd = w->mask.cols;
  const cv::Mat mask = w->mask.clone();
  const cv::Mat rgb = w->rgb.clone(), depth = w->depth.clone();
  const int directions[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < wd; ++x) {
      if (!mask.at<std::uint8_t>(y, x)) continue;
      float best_z = std::numeric_limits<float>::infinity();
      cv::Vec3f best_rgb;
      for (const auto& d : directions) {
        int found[2] = {0, 0};
        for (int side = 0; side < 2; ++side) {
          const int sign = side ? -1 : 1;
          for (int k = 1; k <= kWarpMaxCrack; ++k) {
            const int xx = x + sign * k * d[0], yy = y + sign * k * d[1];
            if (xx < 0 || yy < 0 || xx >= wd || yy >= h) break;
            if (!mask.at<std::uint8_t>(yy, xx)) {
              found[side] = k;
              break;
            }
          }
        }
        if (!found[0] || !found[1]) continue;
        const int ax = x + found[0] * d[0], ay = y + found[0] * d[1];
        const int bx = x - found[1] * d[0], by = y - found[1] * d[1];
        const float za = depth.at<float>(ay, ax), zb = depth.at<float>(by, bx);
        if (std::abs(za - zb) > kWarpDepthTolerance * std::min(za, zb))
          continue;
        const float t = static_cast<float>(found[0]) / (found[0] + found[1]);
        const float z = (1 - t) * za + t * zb;
        if (z >= best_z) continue;
        best_z = z;
        best_rgb =
            (1 - t) * rgb.at<cv::Vec3f>(ay, ax) + t * rgb.at<cv::Vec3f>(by, bx);
      }
      if (!std::isfinite(best_z)) continue;
      w->rgb.at<cv::Vec3f>(y, x) = best_rgb;
      w->depth.at<float>(y, x) = best_z;
      w->mask.at<std::uint8_t>(y, x) = 0;
    }
  }
}

}  // namespace

WarpResult ForwardWarp(const cv::Mat& rgb, const cv::Mat& depth,
                       const RasterCamera& source, const RasterCamera& target,
                       const cv::Mat& valid) {
  CheckInput(rgb, depth, source, valid);
  const int tw = target.width, th = target.height;
  if (tw <= 0 || th <= 0) {
    throw Error("warp", "target", std::to_string(tw) + "x" + std::to_string(th),
                "the target camera has no pixels");
  }
  // target_from_source, applied to source camera-frame points.
  const Eigen::Matrix3f rotation =
      target.rotation * source.rotation.transpose();
  const Eigen::Vector3f translation =
      target.translation - rotation * source.translation;

  std::vector<Landing> landings;
  landings.reserve(static_cast<std::size_t>(rgb.total()));
  std::vector<const cv::Vec3f*> colours;
  colours.reserve(landings.capacity());
  for (int y = 0; y < rgb.rows; ++y) {
    const float* d = depth.ptr<float>(y);
    const cv::Vec3f* c = rgb.ptr<cv::Vec3f>(y);
    const std::uint8_t* ok = valid.empty() ? nullptr : valid.ptr<uint8_t>(y);
    for (int x = 0; x < rgb.cols; ++x) {
      const float z = d[x];
      if (!(z > 0) || !std::isfinite(z) || (ok && !ok[x])) continue;
      const Eigen::Vector3f p_src((x + 0.5f - source.cx) / source.fx * z,
                                  (y + 0.5f - source.cy) / source.fy * z, z);
      const Eigen::Vector3f p = rotation * p_src + translation;
      if (!(p.z() > 0)) continue;
      landings.push_back({target.fx * p.x() / p.z() + target.cx,
                          target.fy * p.y() / p.z() + target.cy, p.z()});
      colours.push_back(&c[x]);
    }
  }

  // Visits the (up to) four target pixels a landing covers with weight at
  // least kWarpMinWeight.
  const auto for_each_cover = [&](const Landing& l, auto&& visit) {
    const float fx = l.u - 0.5f, fy = l.v - 0.5f;
    const int x0 = static_cast<int>(std::floor(fx));
    const int y0 = static_cast<int>(std::floor(fy));
    const float ax = fx - x0, ay = fy - y0;
    for (int dy = 0; dy < 2; ++dy) {
      const int y = y0 + dy;
      if (y < 0 || y >= th) continue;
      const float wy = dy ? ay : 1 - ay;
      for (int dx = 0; dx < 2; ++dx) {
        const int x = x0 + dx;
        if (x < 0 || x >= tw) continue;
        const float w = wy * (dx ? ax : 1 - ax);
        if (w >= kWarpMinWeight) visit(static_cast<std::size_t>(y) * tw + x, w);
      }
    }
  };

  std::vector<float> nearest(static_cast<std::size_t>(tw) * th,
                             std::numeric_limits<float>::infinity());
  for (const Landing& l : landings) {
    if (!(std::abs(l.u) < 1e6f && std::abs(l.v) < 1e6f)) continue;
    for_each_cover(l, [&](std::size_t p, float) {
      nearest[p] = std::min(nearest[p], l.z);
    });
  }
  std::vector<float> weight(nearest.size(), 0.0f), z_sum(nearest.size(), 0.0f);
  std::vector<cv::Vec3f> colour(nearest.size(), cv::Vec3f(0, 0, 0));
  for (std::size_t i = 0; i < landings.size(); ++i) {
    const Landing& l = landings[i];
    if (!(std::abs(l.u) < 1e6f && std::abs(l.v) < 1e6f)) continue;
    for_each_cover(l, [&](std::size_t p, float w) {
      if (l.z > nearest[p] * (1 + kWarpDepthTolerance)) return;
      weight[p] += w;
      z_sum[p] += w * l.z;
      colour[p] += w * *colours[i];
    });
  }

  WarpResult out;
  out.rgb = cv::Mat(th, tw, CV_32FC3, cv::Scalar::all(0));
  out.depth = cv::Mat(th, tw, CV_32FC1, cv::Scalar(0));
  out.mask = cv::Mat(th, tw, CV_8UC1, cv::Scalar(255));
  for (int y = 0; y < th; ++y) {
    for (int x = 0; x < tw; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * tw + x;
      if (!(weight[p] > 0)) continue;
      out.rgb.at<cv::Vec3f>(y, x) = colour[p] / weight[p];
      out.depth.at<float>(y, x) = z_sum[p] / weight[p];
      out.mask.at<std::uint8_t>(y, x) = 0;
    }
  }
  FillCracks(&out);
  return out;
}

int FillHoles(const WarpResult& from, WarpResult* into) {
  if (from.mask.size() != into->mask.size()) {
    throw Error(
        "warp", "chained frame",
        std::to_string(from.mask.cols) + "x" + std::to_string(from.mask.rows),
        "expected the size of the frame it fills, " +
            std::to_string(into->mask.cols) + "x" +
            std::to_string(into->mask.rows));
  }
  int filled = 0;
  for (int y = 0; y < into->mask.rows; ++y) {
    for (int x = 0; x < into->mask.cols; ++x) {
      if (!into->mask.at<std::uint8_t>(y, x) ||
          from.mask.at<std::uint8_t>(y, x))
        continue;
      into->rgb.at<cv::Vec3f>(y, x) = from.rgb.at<cv::Vec3f>(y, x);
      into->depth.at<float>(y, x) = from.depth.at<float>(y, x);
      into->mask.at<std::uint8_t>(y, x) = 0;
      ++filled;
    }
  }
  return filled;
}

}  // namespace pano4d
