#include "src/gs/loss.h"

#include <array>
#include <cmath>
#include <string>

#include <opencv2/core.hpp>

#include "src/core/error.h"
#include "src/core/image.h"

namespace pano4d {
namespace {

constexpr int kWindow = 11;
constexpr int kRadius = kWindow / 2;
constexpr double kSigma = 1.5;
constexpr double kC1 = 0.01 * 0.01;
constexpr double kC2 = 0.03 * 0.03;
// Per pixel: the five local moments (x, y, x^2, y^2, xy) of each channel,
// and the three gradient maps (with respect to mu_x, E[x^2], E[xy]).
constexpr int kMoments = 5 * 3;
constexpr int kGrads = 3 * 3;

// The normalised 11-tap Gaussian window (cv::getGaussianKernel's).
const std::array<double, kWindow>& Window() {
  static const std::array<double, kWindow> window = [] {
    std::array<double, kWindow> w;
    double sum = 0;
    for (int i = 0; i < kWindow; ++i) {
      const double d = i - kRadius;
      w[i] = std::exp(-d * d / (2 * kSigma * kSigma));
      sum += w[i];
    }
    for (double& v : w) v /= sum;
    return w;
  }();
  return window;
}

// Rows are stored plane by plane: a row of k maps is k runs of `width`
// values (map j's pixel px at j * width + px), so that every pass below is a
// loop over contiguous pixels, which the compiler vectorises.

// Horizontal pass of the window over the k maps of one row: `padded` holds
// each map with kRadius zeros on each side (k runs of width + 2 kRadius).
// The window is symmetric: pairs of taps share a multiplication.
template <int k>
void BlurRow(const double* __restrict padded, int width,
             double* __restrict out) {
  const std::array<double, kWindow>& w = Window();
  const int padded_width = width + 2 * kRadius;
  for (int j = 0; j < k; ++j) {
    const double* centre = padded + j * padded_width + kRadius;
    double* o = out + j * width;
    for (int px = 0; px < width; ++px) o[px] = w[kRadius] * centre[px];
    for (int d = 1; d <= kRadius; ++d) {
      const double wd = w[kRadius - d];
      for (int px = 0; px < width; ++px)
        o[px] += wd * (centre[px - d] + centre[px + d]);
    }
  }
}

// Vertical pass at row py of `rows` (height rows of `stride` values, each
// already blurred horizontally), zero padding beyond the image.
void BlurColumn(const double* __restrict rows, int height, int py,
                std::size_t stride, double* __restrict out) {
  const std::array<double, kWindow>& w = Window();
  const double* centre = rows + py * stride;
  for (std::size_t i = 0; i < stride; ++i) out[i] = w[kRadius] * centre[i];
  for (int d = 1; d <= kRadius; ++d) {
    const double wd = w[kRadius - d];
    const bool up = py - d >= 0, down = py + d < height;
    const double* above = centre - d * stride;
    const double* below = centre + d * stride;
    if (up && down) {
      for (std::size_t i = 0; i < stride; ++i)
        out[i] += wd * (above[i] + below[i]);
    } else if (up) {
      for (std::size_t i = 0; i < stride; ++i) out[i] += wd * above[i];
    } else if (down) {
      for (std::size_t i = 0; i < stride; ++i) out[i] += wd * below[i];
    }
  }
}

}  // namespace

PhotometricLoss ComputePhotometricLoss(const std::vector<float>& rendered,
                                       const std::vector<float>& target,
                                       int width, int height,
                                       double ssim_weight,
                                       std::vector<float>* d_rendered,
                                       PhotometricLossBuffers* buffers) {
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
  if (!cv::checkRange(MatView(rendered, height, width, 3)) ||
      !cv::checkRange(MatView(target, height, width, 3)))
    throw Error("photometric loss", "image", "", "holds NaN or infinity");

  PhotometricLossBuffers local;
  PhotometricLossBuffers& b = buffers != nullptr ? *buffers : local;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  const std::size_t moment_stride = static_cast<std::size_t>(width) * kMoments;
  const std::size_t grad_stride = static_cast<std::size_t>(width) * kGrads;
  b.rows.resize(pixels * kMoments);     // moments blurred horizontally
  b.moments.resize(pixels * kMoments);  // ... and vertically
  b.grads.resize(pixels * kGrads);
  b.blurred.resize(pixels * kGrads);
  std::vector<double> ssim_rows(height), l1_rows(height), mse_rows(height);
  if (d_rendered != nullptr) d_rendered->resize(n);
  const double scale = 1.0 / static_cast<double>(n);
  // d(ssim_weight (1 - mean S)) / dS.
  const double d_s = -ssim_weight * scale;
  const float* x = rendered.data();
  const float* y = target.data();

#pragma omp parallel
  {
    const std::size_t padded_width =
        static_cast<std::size_t>(width) + 2 * kRadius;
    std::vector<double> padded(padded_width * kMoments, 0.0);
    // The moments of each row, blurred along it. Map q * 3 + c is moment q
    // (x, y, x^2, y^2, xy) of channel c.
#pragma omp for schedule(static)
    for (int py = 0; py < height; ++py) {
      const float* xr = x + static_cast<std::size_t>(py) * width * 3;
      const float* yr = y + static_cast<std::size_t>(py) * width * 3;
      for (int c = 0; c < 3; ++c) {
        double* m[5];
        for (int q = 0; q < 5; ++q)
          m[q] = &padded[(q * 3 + c) * padded_width + kRadius];
        for (int px = 0; px < width; ++px) {
          const double xv = xr[px * 3 + c], yv = yr[px * 3 + c];
          m[0][px] = xv;
          m[1][px] = yv;
          m[2][px] = xv * xv;
          m[3][px] = yv * yv;
          m[4][px] = xv * yv;
        }
      }
      BlurRow<kMoments>(padded.data(), width, &b.rows[py * moment_stride]);
    }
    // Down the columns, then SSIM and its gradient maps per pixel (map
    // c, 3 + c and 6 + c: with respect to mu_x, E[x^2] and E[xy]).
#pragma omp for schedule(static)
    for (int py = 0; py < height; ++py) {
      double* row = &b.moments[py * moment_stride];
      BlurColumn(b.rows.data(), height, py, moment_stride, row);
      double* g = &b.grads[py * grad_stride];
      double ssim = 0;
      for (int c = 0; c < 3; ++c) {
        const double *mu_x = row + c * width, *mu_y = row + (3 + c) * width,
                     *e_xx = row + (6 + c) * width,
                     *e_yy = row + (9 + c) * width,
                     *e_xy = row + (12 + c) * width;
        double *g_mu = g + c * width, *g_xx = g + (3 + c) * width,
               *g_xy = g + (6 + c) * width;
        for (int px = 0; px < width; ++px) {
          const double mx = mu_x[px], my = mu_y[px];
          const double a1 = 2 * mx * my + kC1;
          const double a2 = 2 * (e_xy[px] - mx * my) + kC2;
          const double b1 = mx * mx + my * my + kC1;
          const double b2 = (e_xx[px] - mx * mx) + (e_yy[px] - my * my) + kC2;
          const double s = a1 * a2 / (b1 * b2);
          ssim += s;
          // S = A1 A2 / (B1 B2) as a function of mu_x, E[x^2] and E[xy].
          g_mu[px] = d_s * (2 * my * (a2 - a1) / (b1 * b2) -
                            2 * mx * s * (1 / b1 - 1 / b2));
          g_xx[px] = d_s * (-s / b2);
          g_xy[px] = d_s * (2 * a1 / (b1 * b2));
        }
      }
      ssim_rows[py] = ssim;
    }
    // The window is symmetric and zero padding makes the filter
    // self-adjoint: the backward blurs the gradient maps the same way.
    std::fill(padded.begin(), padded.end(), 0.0);
#pragma omp for schedule(static)
    for (int py = 0; py < height; ++py) {
      const double* g = &b.grads[py * grad_stride];
      for (int j = 0; j < kGrads; ++j)
        std::copy(g + j * width, g + (j + 1) * width,
                  padded.begin() + j * padded_width + kRadius);
      BlurRow<kGrads>(padded.data(), width, &b.rows[py * grad_stride]);
    }
#pragma omp for schedule(static)
    for (int py = 0; py < height; ++py) {
      double* blurred = &b.blurred[py * grad_stride];
      BlurColumn(b.rows.data(), height, py, grad_stride, blurred);
      const std::size_t first = static_cast<std::size_t>(py) * width * 3;
      double l1 = 0, mse = 0;
      for (int c = 0; c < 3; ++c) {
        const double *g_mu = blurred + c * width,
                     *g_xx = blurred + (3 + c) * width,
                     *g_xy = blurred + (6 + c) * width;
        for (int px = 0; px < width; ++px) {
          const std::size_t i = first + px * 3 + c;
          const double xv = x[i], yv = y[i], diff = xv - yv;
          l1 += std::abs(diff);
          mse += diff * diff;
          if (d_rendered == nullptr) continue;
          // d|d|/dd = sign(d), 0 at 0 (a subgradient).
          const double d_l1 =
              (1 - ssim_weight) * scale * ((diff > 0) - (diff < 0));
          (*d_rendered)[i] = static_cast<float>(
              d_l1 + g_mu[px] + 2 * xv * g_xx[px] + yv * g_xy[px]);
        }
      }
      l1_rows[py] = l1;
      mse_rows[py] = mse;
    }
  }

  PhotometricLoss loss;
  for (int py = 0; py < height; ++py) {
    loss.ssim += ssim_rows[py];
    loss.l1 += l1_rows[py];
    loss.mse += mse_rows[py];
  }
  loss.l1 *= scale;
  loss.mse *= scale;
  loss.ssim *= scale;
  loss.total = (1 - ssim_weight) * loss.l1 + ssim_weight * (1 - loss.ssim);
  return loss;
}

}  // namespace pano4d
