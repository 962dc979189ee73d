#pragma once

#include <opencv2/core.hpp>

namespace pano4d {

// cv::inpaint (Telea) for float images of any channel count: the pixels of
// `image` where `mask` (CV_8UC1) is non-zero are filled from around them.
// Values are taken as lying in [0, max_value] (max_value > 0).
//
// Why not cv::inpaint directly: it has no 3-channel float path, and its
// 1-channel float path is broken before OpenCV 4.10 (opencv/opencv#25404:
// a smooth ramp in [0, 0.9] came back with values from -0.6 to 2.4 inside
// the hole on Debian's 4.6). Each channel is inpainted as 16-bit fixed
// point instead, which is exact to max_value / 65535. A 1-pixel masked
// border works around holes touching the top or left edge
// (opencv/opencv#25389).
cv::Mat InpaintTelea(const cv::Mat& image, const cv::Mat& mask,
                     double max_value, double radius);

// Depth for the pixels of a hole (mask non-zero, or depth <= 0): each takes
// the farthest of the nearest known depths to its left, right, above and
// below. A hole the video never saw is mostly a disocclusion,
// the background behind a nearer object: averaging (Telea) would put its
// points in mid-air between the two and float them in front of what other
// views see. Pixels that no known depth reaches stay 0.
cv::Mat FillDepthFromFarthest(const cv::Mat& depth, const cv::Mat& mask);

}  // namespace pano4d
