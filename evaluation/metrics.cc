#include "evaluation/metrics.h"

#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "src/core/error.h"
#include "src/core/psnr.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

// DyCheck's masked_mean divides by max(sum(mask), eps).
constexpr double kMaskedMeanEps = 1e-6;
constexpr double kSsimSigma = 1.5;
constexpr double kSsimK1 = 0.01;
constexpr double kSsimK2 = 0.03;

void CheckPair(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  if (a.type() != CV_64FC3 || b.type() != CV_64FC3) {
    throw Error("metrics", "type",
                std::to_string(a.type()) + "/" + std::to_string(b.type()),
                "images must come from QuantizeForMetrics (CV_64FC3)");
  }
  if (a.size() != b.size()) {
    throw Error("metrics", "size",
                SizeText(a.cols, a.rows) + " vs " + SizeText(b.cols, b.rows),
                "the two images must have the same size");
  }
  if (!mask.empty() && (mask.type() != CV_64FC1 || mask.size() != a.size())) {
    throw Error(
        "metrics", "mask",
        SizeText(mask.cols, mask.rows) + " type " + std::to_string(mask.type()),
        "the mask must come from MetricMask and match the image size " +
            SizeText(a.cols, a.rows));
  }
}

std::array<double, kSsimWindow> GaussianFilter() {
  // DyCheck: f_i = ((i - hw + shift) / sigma)^2, shift = 0 for odd sizes.
  std::array<double, kSsimWindow> f{};
  double sum = 0;
  for (int i = 0; i < kSsimWindow; ++i) {
    const double x = (i - kSsimWindow / 2) / kSsimSigma;
    f[i] = std::exp(-0.5 * x * x);
    sum += f[i];
  }
  for (double& v : f) v /= sum;
  return f;
}

// One pass of DyCheck's partial convolution, valid mode, along x when
// `along_x` (else y): z' = conv(z m, f) * 11 / conv(m, ones), 0 where
// conv(m, ones) = 0. Returns z' and sets `next_mask` to (conv(m, ones) != 0).
cv::Mat PartialConv(const cv::Mat& z, const cv::Mat& m, bool along_x,
                    cv::Mat* next_mask) {
  static const std::array<double, kSsimWindow> f = GaussianFilter();
  const int rows = along_x ? z.rows : z.rows - (kSsimWindow - 1);
  const int cols = along_x ? z.cols - (kSsimWindow - 1) : z.cols;
  cv::Mat out(rows, cols, CV_64FC1);
  next_mask->create(rows, cols, CV_64FC1);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      double weighted = 0, count = 0;
      for (int k = 0; k < kSsimWindow; ++k) {
        const int yy = along_x ? y : y + k;
        const int xx = along_x ? x + k : x;
        const double mk = m.at<double>(yy, xx);
        weighted += f[k] * z.at<double>(yy, xx) * mk;
        count += mk;
      }
      out.at<double>(y, x) = count != 0 ? weighted * kSsimWindow / count : 0.0;
      next_mask->at<double>(y, x) = count != 0 ? 1.0 : 0.0;
    }
  }
  return out;
}

// filt_fn of DyCheck: along W first, then H with the first pass's mask.
cv::Mat Blur(const cv::Mat& z, const cv::Mat& m, cv::Mat* final_mask) {
  cv::Mat m1;
  const cv::Mat pass1 = PartialConv(z, m, /*along_x=*/true, &m1);
  return PartialConv(pass1, m1, /*along_x=*/false, final_mask);
}

}  // namespace

cv::Mat QuantizeForMetrics(const Image& image, const std::string& source) {
  if (image.empty()) throw Error::In(source, "image is empty");
  if (!image.AllFinite()) {
    throw Error::In(source,
                    "image has NaN or infinite pixels; cannot score it");
  }
  cv::Mat out(image.height(), image.width(), CV_64FC3);
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const cv::Vec3f& p = image.at(x, y);
      cv::Vec3d& q = out.at<cv::Vec3d>(y, x);
      for (int c = 0; c < 3; ++c) {
        const double clipped =
            std::min(255.0, std::max(0.0, static_cast<double>(p[c]) * 255.0));
        q[c] = std::floor(clipped) / 255.0;
      }
    }
  }
  return out;
}

cv::Mat MetricMask(const cv::Mat& mask, const std::string& source) {
  if (mask.empty()) throw Error::In(source, "mask is empty");
  cv::Mat channel = mask;
  if (mask.channels() > 1) cv::extractChannel(mask, channel, 0);
  cv::Mat out(channel.rows, channel.cols, CV_64FC1);
  cv::Mat as_double;
  channel.convertTo(as_double, CV_64F);
  const double threshold = channel.depth() == CV_8U    ? 128.0
                           : channel.depth() == CV_16U ? 32768.0
                                                       : 0.5;
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      const double v = as_double.at<double>(y, x);
      if (!std::isfinite(v))
        throw Error::In(source, "mask has NaN or infinite values");
      out.at<double>(y, x) = v >= threshold ? 1.0 : 0.0;
    }
  }
  return out;
}

cv::Mat InvertMask(const cv::Mat& mask) {
  cv::Mat out;
  cv::subtract(cv::Scalar::all(1.0), mask, out);
  return out;
}

std::optional<double> Psnr(const cv::Mat& a, const cv::Mat& b,
                           const cv::Mat& mask) {
  CheckPair(a, b, mask);
  double sum = 0, weight = 0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      const double m = mask.empty() ? 1.0 : mask.at<double>(y, x);
      if (m == 0) continue;
      const cv::Vec3d d = a.at<cv::Vec3d>(y, x) - b.at<cv::Vec3d>(y, x);
      sum += m * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      weight += 3 * m;  // the mask broadcast to three channels
    }
  }
  if (weight == 0) return std::nullopt;
  return PsnrFromMse(sum / std::max(weight, kMaskedMeanEps));
}

std::optional<SsimValue> Ssim(const cv::Mat& a, const cv::Mat& b,
                              const cv::Mat& mask) {
  CheckPair(a, b, mask);
  if (a.rows < kSsimWindow || a.cols < kSsimWindow) {
    throw Error(
        "metrics", "size", SizeText(a.cols, a.rows),
        "SSIM needs images of at least " + SizeText(kSsimWindow, kSsimWindow));
  }
  const cv::Mat m =
      mask.empty() ? cv::Mat(a.size(), CV_64FC1, cv::Scalar(1.0)) : mask;
  if (cv::countNonZero(m) == 0) return std::nullopt;

  const double c1 = kSsimK1 * kSsimK1;
  const double c2 = kSsimK2 * kSsimK2;
  double total = 0, strict_total = 0;
  std::int64_t entries = 0, strict_entries = 0;
  std::array<cv::Mat, 3> a_planes, b_planes;
  cv::split(a, a_planes.data());
  cv::split(b, b_planes.data());
  for (int c = 0; c < 3; ++c) {
    const cv::Mat& x = a_planes[c];
    const cv::Mat& y = b_planes[c];
    cv::Mat valid;
    const cv::Mat mu0 = Blur(x, m, &valid);
    const cv::Mat mu1 = Blur(y, m, &valid);
    const cv::Mat e00 = Blur(x.mul(x), m, &valid);
    const cv::Mat e11 = Blur(y.mul(y), m, &valid);
    const cv::Mat e01 = Blur(x.mul(y), m, &valid);
    for (int r = 0; r < valid.rows; ++r) {
      for (int q = 0; q < valid.cols; ++q) {
        const double m0 = mu0.at<double>(r, q), m1 = mu1.at<double>(r, q);
        const double s00 = std::max(0.0, e00.at<double>(r, q) - m0 * m0);
        const double s11 = std::max(0.0, e11.at<double>(r, q) - m1 * m1);
        double s01 = e01.at<double>(r, q) - m0 * m1;
        s01 = std::copysign(std::min(std::sqrt(s00 * s11), std::abs(s01)), s01);
        const double value = ((2 * m0 * m1 + c1) * (2 * s01 + c2)) /
                             ((m0 * m0 + m1 * m1 + c1) * (s00 + s11 + c2));
        total += value;
        ++entries;
        if (valid.at<double>(r, q) != 0) {
          strict_total += value;
          ++strict_entries;
        }
      }
    }
  }
  SsimValue out;
  out.dycheck = total / entries;
  out.strict = strict_total / strict_entries;  // > 0: the mask is not empty
  return out;
}

}  // namespace pano4d
