#include "src/gs/loss.h"

#include <cmath>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/image.h"

namespace pano4d {
namespace {

constexpr int kWindow = 11;
constexpr double kSigma = 1.5;
constexpr double kC1 = 0.01 * 0.01;
constexpr double kC2 = 0.03 * 0.03;

// Gaussian window filter with zero padding. The filter is symmetric and
// zero padding makes it self-adjoint, so the backward pass filters too.
cv::Mat Blur(const cv::Mat& m) {
  static const cv::Mat kernel = cv::getGaussianKernel(kWindow, kSigma, CV_64F);
  cv::Mat out;
  cv::sepFilter2D(m, out, CV_64F, kernel, kernel, cv::Point(-1, -1), 0,
                  cv::BORDER_CONSTANT);
  return out;
}

}  // namespace

PhotometricLoss ComputePhotometricLoss(const std::vector<float>& rendered,
                                       const std::vector<float>& target,
                                       int width, int height,
                                       double ssim_weight,
                                       std::vector<float>* d_rendered) {
  const std::size_t n = static_cast<std::size_t>(width) * height * 3;
  if (width <= 0 || height <= 0 || rendered.size() != n || target.size() != n) {
    throw Error("photometric loss", "size",
                std::to_string(rendered.size()) + " and " +
                    std::to_string(target.size()),
                "expected " + std::to_string(n) + " values (" +
                    std::to_string(width) + "x" + std::to_string(height) +
                    "x3)");
  }
  if (!(ssim_weight >= 0 && ssim_weight <= 1))
    throw Error("photometric loss", "ssim_weight", std::to_string(ssim_weight),
                "must be in [0, 1]");
  const cv::Mat r = MatView(rendered, height, width, 3);
  const cv::Mat t = MatView(target, height, width, 3);
  if (!cv::checkRange(r) || !cv::checkRange(t))
    throw Error("photometric loss", "image", "", "holds NaN or infinity");

  PhotometricLoss loss;
  if (d_rendered != nullptr) d_rendered->assign(n, 0.0f);
  cv::Mat r_planes[3], t_planes[3];
  cv::split(r, r_planes);
  cv::split(t, t_planes);
  const double scale = 1.0 / static_cast<double>(n);
  for (int c = 0; c < 3; ++c) {
    cv::Mat x, y;
    r_planes[c].convertTo(x, CV_64F);
    t_planes[c].convertTo(y, CV_64F);
    const cv::Mat mu_x = Blur(x), mu_y = Blur(y);
    const cv::Mat e_xx = Blur(x.mul(x)), e_yy = Blur(y.mul(y)),
                  e_xy = Blur(x.mul(y));
    cv::Mat g_mu(height, width, CV_64F), g_xx(height, width, CV_64F),
        g_xy(height, width, CV_64F);
    // d(ssim_weight (1 - mean S)) / dS.
    const double d_s = -ssim_weight * scale;
    for (int py = 0; py < height; ++py) {
      for (int px = 0; px < width; ++px) {
        const double mx = mu_x.at<double>(py, px), my = mu_y.at<double>(py, px);
        const double a1 = 2 * mx * my + kC1;
        const double a2 = 2 * (e_xy.at<double>(py, px) - mx * my) + kC2;
        const double b1 = mx * mx + my * my + kC1;
        const double b2 = (e_xx.at<double>(py, px) - mx * mx) +
                          (e_yy.at<double>(py, px) - my * my) + kC2;
        const double s = a1 * a2 / (b1 * b2);
        loss.ssim += s;
        // S = A1 A2 / (B1 B2) as a function of mu_x, E[x^2] and E[xy].
        g_mu.at<double>(py, px) = d_s * (2 * my * (a2 - a1) / (b1 * b2) -
                                         2 * mx * s * (1 / b1 - 1 / b2));
        g_xx.at<double>(py, px) = d_s * (-s / b2);
        g_xy.at<double>(py, px) = d_s * (2 * a1 / (b1 * b2));
      }
    }
    const cv::Mat grad = Blur(g_mu) + 2 * x.mul(Blur(g_xx)) + y.mul(Blur(g_xy));
    for (int py = 0; py < height; ++py) {
      for (int px = 0; px < width; ++px) {
        const double diff = x.at<double>(py, px) - y.at<double>(py, px);
        loss.l1 += std::abs(diff);
        if (d_rendered == nullptr) continue;
        // d|d|/dd = sign(d), 0 at 0 (a subgradient).
        const double d_l1 =
            (1 - ssim_weight) * scale * ((diff > 0) - (diff < 0));
        (*d_rendered)[(static_cast<std::size_t>(py) * width + px) * 3 + c] =
            static_cast<float>(d_l1 + grad.at<double>(py, px));
      }
    }
  }
  loss.l1 *= scale;
  loss.ssim *= scale;
  loss.total = (1 - ssim_weight) * loss.l1 + ssim_weight * (1 - loss.ssim);
  return loss;
}

}  // namespace pano4d
