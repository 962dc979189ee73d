#pragma once

#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "src/core/image.h"

namespace pano4d {

// Image metrics exactly as DyCheck computes them (dycheck/core/metrics/
// image.py, dycheck/nn/functional/common.py), on images quantised first.
//
// Inputs: CV_64FC3 images from QuantizeForMetrics, and optional CV_64FC1
// masks in {0, 1} from MetricMask (an empty cv::Mat means "every pixel").
// A masked metric over a mask that selects no pixel is undefined and comes
// back as nullopt (DyCheck would report +inf dB there); callers leave such
// frames out of their means and say how many they left out.

// DyCheck scores 8-bit images: clip to [0, 1], x * 255 truncated to an
// integer, / 255. Throws pano4d::Error naming `source` if a pixel is NaN or
// infinite (a silent NaN would poison every mean).
cv::Mat QuantizeForMetrics(const Image& image, const std::string& source);

// A {0, 1} mask from an 8-bit mask (>= 128 is 1, as 0/255 PNGs are written)
// or a float mask (>= 0.5 is 1).
cv::Mat MetricMask(const cv::Mat& mask, const std::string& source);
// 1 - mask: the unseen pixels, for the u* metrics.
cv::Mat InvertMask(const cv::Mat& mask);

// PSNR in dB: -10 log10(sum(m (a - b)^2) / sum(m)), the mask broadcast to the
// three channels. +inf for identical images.
std::optional<double> Psnr(const cv::Mat& a, const cv::Mat& b,
                           const cv::Mat& mask = {});

// SSIM: 11-tap Gaussian (sigma 1.5), k1 = 0.01, k2 = 0.03, data range 1,
// separable valid convolution (along W, then H) made partial by the mask.
// `dycheck` is DyCheck's value: the plain mean of the (H - 10) x (W - 10) x 3
// map, in which windows wholly outside the mask count as 1.0. `strict`
// averages only the windows that hold at least one masked pixel. Without a
// mask both equal scikit-image's structural_similarity(gaussian_weights=True,
// sigma=1.5, use_sample_covariance=False, data_range=1, channel_axis=-1).
struct SsimValue {
  double dycheck = 0.0;
  double strict = 0.0;
};
std::optional<SsimValue> Ssim(const cv::Mat& a, const cv::Mat& b,
                              const cv::Mat& mask = {});

// SSIM needs images at least this large (one full window).
inline constexpr int kSsimWindow = 11;

}  // namespace pano4d
