#include "src/gs/loss.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <omp.h>
#include <opencv2/core.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/strings.h"

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

// Vertical pass at one row: rows[i] is image row py - kRadius + i, already
// blurred horizontally (`stride` values), or null beyond the image (zero
// padding).
void BlurColumn(const double* const* rows, std::size_t stride,
                double* __restrict out) {
  const std::array<double, kWindow>& w = Window();
  const double* centre = rows[kRadius];
  for (std::size_t i = 0; i < stride; ++i) out[i] = w[kRadius] * centre[i];
  for (int d = 1; d <= kRadius; ++d) {
    const double wd = w[kRadius - d];
    const double* above = rows[kRadius - d];
    const double* below = rows[kRadius + d];
    if (above != nullptr && below != nullptr) {
      for (std::size_t i = 0; i < stride; ++i)
        out[i] += wd * (above[i] + below[i]);
    } else if (above != nullptr) {
      for (std::size_t i = 0; i < stride; ++i) out[i] += wd * above[i];
    } else if (below != nullptr) {
      for (std::size_t i = 0; i < stride; ++i) out[i] += wd * below[i];
    }
  }
}

// The kWindow rows centred on py held in `ring` (row r in slot r mod
// kWindow, `stride` values a row), null beyond the image.
void RingRows(double* ring, std::size_t stride, int py, int height,
              const double* rows[kWindow]) {
  for (int i = 0; i < kWindow; ++i) {
    const int r = py - kRadius + i;
    rows[i] = r >= 0 && r < height ? ring + (r % kWindow) * stride : nullptr;
  }
}

// One evaluation of the photometric loss, streamed band by band: each
// thread takes one band of rows [r0, r1) through three passes, kRadius rows
// apart, so that its maps stay in the cache: (1) a row's moments blurred
// along it, into a ring of kWindow rows; (2) kRadius rows behind, those
// blurred down the columns, SSIM and its gradient maps, blurred along the
// row into a second ring; (3) kRadius rows further behind, the gradient
// maps blurred down the columns and dL/dr. A band recomputes the
// 2 kRadius rows of (1) and kRadius rows of (2) beyond its edges that it
// reads; they are the same values whoever computes them, so the result does
// not depend on the thread count.
struct PhotometricPass {
  const float* x;  // rendered
  const float* y;  // target
  int width, height;
  double ssim_weight;
  double scale;  // 1 / values
  double d_s;    // d(ssim_weight (1 - mean S)) / dS
  std::vector<float>* d_rendered;
  double *ssim_rows, *l1_rows, *mse_rows;
  std::size_t moment_stride, grad_stride, padded_width;

  std::size_t ScratchSize() const {
    return kWindow * (moment_stride + grad_stride) + padded_width * kMoments +
           moment_stride + 2 * grad_stride;
  }
  void Band(int band, int bands, std::vector<double>* scratch) const;
  void MomentRow(int t, double* padded, double* slot) const;
  double SsimRow(const double* moments, double* grads, double* padded,
                 double* slot) const;
  void LossRow(int pz, const double* blurred) const;
};

// (1) Row t's moments, blurred along it. Map q * 3 + c is moment q (x, y,
// x^2, y^2, xy) of channel c.
void PhotometricPass::MomentRow(int t, double* padded, double* slot) const {
  const float* xr = x + static_cast<std::size_t>(t) * width * 3;
  const float* yr = y + static_cast<std::size_t>(t) * width * 3;
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
  BlurRow<kMoments>(padded, width, slot);
}

// (2) A row's SSIM from its blurred `moments`, and its gradient maps (map
// c, 3 + c and 6 + c: with respect to mu_x, E[x^2] and E[xy]) blurred along
// the row into `slot`. Returns the row's sum of SSIM.
double PhotometricPass::SsimRow(const double* moments, double* grads,
                                double* padded, double* slot) const {
  double ssim = 0;
  for (int c = 0; c < 3; ++c) {
    const double *mu_x = moments + c * width, *mu_y = moments + (3 + c) * width,
                 *e_xx = moments + (6 + c) * width,
                 *e_yy = moments + (9 + c) * width,
                 *e_xy = moments + (12 + c) * width;
    double *g_mu = grads + c * width, *g_xx = grads + (3 + c) * width,
           *g_xy = grads + (6 + c) * width;
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
  // The window is symmetric and zero padding makes the filter
  // self-adjoint: the backward blurs the gradient maps the same way.
  for (int j = 0; j < kGrads; ++j)
    std::copy(grads + j * width, grads + (j + 1) * width,
              padded + j * padded_width + kRadius);
  BlurRow<kGrads>(padded, width, slot);
  return ssim;
}

// (3) Row pz: L1, squared error and dL/dr from the `blurred` gradient maps.
void PhotometricPass::LossRow(int pz, const double* blurred) const {
  const std::size_t first_value = static_cast<std::size_t>(pz) * width * 3;
  double l1 = 0, mse = 0;
  for (int c = 0; c < 3; ++c) {
    const double *g_mu = blurred + c * width, *g_xx = blurred + (3 + c) * width,
                 *g_xy = blurred + (6 + c) * width;
    for (int px = 0; px < width; ++px) {
      const std::size_t i = first_value + px * 3 + c;
      const double xv = x[i], yv = y[i], diff = xv - yv;
      l1 += std::abs(diff);
      mse += diff * diff;
      if (d_rendered == nullptr) continue;
      // d|d|/dd = sign(d), 0 at 0 (a subgradient).
      const double d_l1 = (1 - ssim_weight) * scale * ((diff > 0) - (diff < 0));
      (*d_rendered)[i] = static_cast<float>(d_l1 + g_mu[px] +
                                            2 * xv * g_xx[px] + yv * g_xy[px]);
    }
  }
  l1_rows[pz] = l1;
  mse_rows[pz] = mse;
}

void PhotometricPass::Band(int band, int bands,
                           std::vector<double>* scratch) const {
  // Every value is written before it is read but the padding of `padded`,
  // zeros from the first call on.
  if (scratch->size() != ScratchSize()) scratch->assign(ScratchSize(), 0.0);
  double* moment_ring = scratch->data();
  double* grad_ring = moment_ring + kWindow * moment_stride;
  double* padded = grad_ring + kWindow * grad_stride;
  double* moments = padded + padded_width * kMoments;
  double* grads = moments + moment_stride;
  double* blurred = grads + grad_stride;
  const double* rows[kWindow];

  const int r0 = height * band / bands, r1 = height * (band + 1) / bands;
  const int first = std::max(0, r0 - 2 * kRadius);
  const int last = std::min(height, r1 + 2 * kRadius);
  const int grads_first = std::max(0, r0 - kRadius);
  const int grads_last = std::min(height, r1 + kRadius);
  for (int t = first; r0 < r1 && t < r1 + 2 * kRadius; ++t) {
    if (t < last)
      MomentRow(t, padded, moment_ring + (t % kWindow) * moment_stride);
    const int py = t - kRadius;
    if (py >= grads_first && py < grads_last) {
      RingRows(moment_ring, moment_stride, py, height, rows);
      BlurColumn(rows, moment_stride, moments);
      const double ssim = SsimRow(moments, grads, padded,
                                  grad_ring + (py % kWindow) * grad_stride);
      if (py >= r0 && py < r1) ssim_rows[py] = ssim;
    }
    const int pz = t - 2 * kRadius;
    if (pz >= r0 && pz < r1) {
      RingRows(grad_ring, grad_stride, pz, height, rows);
      BlurColumn(rows, grad_stride, blurred);
      LossRow(pz, blurred);
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
                    SizeText(width, height) + "x3)");
  }
  if (!(ssim_weight >= 0 && ssim_weight <= 1))
    throw Error("photometric loss", "ssim_weight", std::to_string(ssim_weight),
                "must be in [0, 1]");
  if (!cv::checkRange(MatView(rendered, height, width, 3)) ||
      !cv::checkRange(MatView(target, height, width, 3)))
    throw Error("photometric loss", "image", "", "holds NaN or infinity");

  PhotometricLossBuffers local;
  PhotometricLossBuffers& b = buffers != nullptr ? *buffers : local;
  std::vector<double> ssim_rows(height), l1_rows(height), mse_rows(height);
  if (d_rendered != nullptr) d_rendered->resize(n);
  const double scale = 1.0 / static_cast<double>(n);
  const PhotometricPass pass{rendered.data(),
                             target.data(),
                             width,
                             height,
                             ssim_weight,
                             scale,
                             -ssim_weight * scale,
                             d_rendered,
                             ssim_rows.data(),
                             l1_rows.data(),
                             mse_rows.data(),
                             static_cast<std::size_t>(width) * kMoments,
                             static_cast<std::size_t>(width) * kGrads,
                             static_cast<std::size_t>(width) + 2 * kRadius};
#pragma omp parallel
  {
    const int bands = omp_get_num_threads(), band = omp_get_thread_num();
#pragma omp single
    b.threads.resize(bands);
    pass.Band(band, bands, &b.threads[band]);
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

namespace {

// Rows per block of BlockSum.
constexpr std::size_t kSumBlock = 4096;

// The sum of term(i) over i < n, rows in parallel: blocks of kSumBlock rows
// are summed in order, so the sum does not depend on the thread count.
// term(i) may write to row i's own entries.
template <typename Term>
double BlockSum(std::size_t n, Term&& term) {
  const std::ptrdiff_t blocks =
      static_cast<std::ptrdiff_t>((n + kSumBlock - 1) / kSumBlock);
  std::vector<double> sums(blocks, 0.0);
  // One block is not worth waking the worker threads for.
#pragma omp parallel for schedule(static) if (blocks > 1)
  for (std::ptrdiff_t b = 0; b < blocks; ++b) {
    const std::size_t end = std::min(n, (b + 1) * kSumBlock);
    for (std::size_t i = b * kSumBlock; i < end; ++i) sums[b] += term(i);
  }
  double total = 0;
  for (double v : sums) total += v;
  return total;
}

}  // namespace

double DepthL1Loss(const std::vector<float>& rendered,
                   const std::vector<float>& given, float median, double weight,
                   std::vector<float>* d_depth) {
  d_depth->assign(given.size(), 0.0f);
  std::size_t count = 0;
  for (float d : given) count += d > 0;
  double sum = 0;
  const double scale = 1.0 / (static_cast<double>(count) * median);
  const float g = static_cast<float>(weight * scale);
  for (std::size_t p = 0; p < given.size(); ++p) {
    if (!(given[p] > 0)) continue;
    const float diff = rendered[p] - given[p];
    sum += std::abs(diff);
    (*d_depth)[p] = diff > 0 ? g : (diff < 0 ? -g : 0.0f);
  }
  return weight * sum * scale;
}

double AnisotropyLoss(const std::vector<float>& log_scales, double bound,
                      double norm, std::vector<float>* d_log_scales) {
  return BlockSum(log_scales.size() / 3, [&](std::size_t i) {
    const float* s = &log_scales[i * 3];
    const int hi = static_cast<int>(std::max_element(s, s + 3) - s);
    const int lo = static_cast<int>(std::min_element(s, s + 3) - s);
    const double ratio = std::exp(double(s[hi]) - s[lo]);
    if (ratio <= bound) return 0.0;
    (*d_log_scales)[i * 3 + hi] += static_cast<float>(norm * ratio);
    (*d_log_scales)[i * 3 + lo] -= static_cast<float>(norm * ratio);
    return norm * (ratio - bound);
  });
}

}  // namespace pano4d
