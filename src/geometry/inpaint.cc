#include "src/geometry/inpaint.h"

#include <algorithm>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include "src/core/error.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

cv::Mat InpaintChannel(const cv::Mat& channel, const cv::Mat& mask,
                       double max_value, double radius) {
  const double scale = 65535.0 / max_value;
  cv::Mat fixed, padded_mask, filled;
  channel.convertTo(fixed, CV_16U, scale);
  cv::copyMakeBorder(fixed, fixed, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
  cv::copyMakeBorder(mask, padded_mask, 1, 1, 1, 1, cv::BORDER_CONSTANT, 255);
  cv::inpaint(fixed, padded_mask, filled, radius, cv::INPAINT_TELEA);
  cv::Mat out;
  filled(cv::Rect(1, 1, channel.cols, channel.rows))
      .convertTo(out, CV_32F, 1.0 / scale);
  return out;
}

}  // namespace

cv::Mat InpaintTelea(const cv::Mat& image, const cv::Mat& mask,
                     double max_value, double radius) {
  if (image.depth() != CV_32F || mask.type() != CV_8UC1 ||
      mask.size() != image.size()) {
    throw Error("inpaint", "image/mask", SizeText(image.cols, image.rows),
                "expected a float image and a CV_8UC1 mask of its size");
  }
  if (!(max_value > 0)) {
    throw Error("inpaint", "max_value", std::to_string(max_value),
                "must be positive");
  }
  // Telea's fast-marching order depends on the mask alone: channel by
  // channel is the same as all at once.
  std::vector<cv::Mat> channels;
  cv::split(image, channels);
  for (cv::Mat& channel : channels)
    channel = InpaintChannel(channel, mask, max_value, radius);
  cv::Mat out;
  cv::merge(channels, out);
  return out;
}

cv::Mat FillDepthFromFarthest(const cv::Mat& depth, const cv::Mat& mask) {
  if (depth.type() != CV_32FC1 || mask.type() != CV_8UC1 ||
      mask.size() != depth.size()) {
    throw Error("depth fill", "depth/mask", SizeText(depth.cols, depth.rows),
                "expected a CV_32FC1 depth map and a CV_8UC1 mask of its size");
  }
  cv::Mat known = depth.clone();
  known.setTo(0, mask);
  cv::Mat out = known.clone();
  const int directions[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (int y = 0; y < known.rows; ++y) {
    for (int x = 0; x < known.cols; ++x) {
      if (known.at<float>(y, x) > 0) continue;
      float farthest = 0;
      for (const auto& d : directions) {
        for (int xx = x + d[0], yy = y + d[1];
             xx >= 0 && yy >= 0 && xx < known.cols && yy < known.rows;
             xx += d[0], yy += d[1]) {
          const float z = known.at<float>(yy, xx);
          if (z > 0) {
            farthest = std::max(farthest, z);
            break;
          }
        }
      }
      out.at<float>(y, x) = farthest;
    }
  }
  return out;
}

}  // namespace pano4d
