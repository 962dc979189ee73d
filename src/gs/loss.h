#pragma once

#include <vector>

namespace pano4d {

// The photometric loss of 3D Gaussian splatting and its gradient:
//   L = (1 - lambda) mean|r - t| + lambda (1 - mean SSIM(r, t)),
// SSIM with an 11-tap Gaussian window (sigma 1.5, C1 = 0.01^2, C2 = 0.03^2)
// over each colour channel, zero padding at the border ("same" size, as the
// 3DGS reference; DyCheck's evaluation SSIM in evaluation/metrics.h uses
// valid windows instead). Images are H x W x 3 interleaved, as
// RenderOutput::rgb.
inline constexpr double kDefaultSsimWeight = 0.2;  // 3DGS's lambda_dssim

struct PhotometricLoss {
  double l1 = 0.0;     // mean |r - t|
  double ssim = 0.0;   // mean SSIM
  double mse = 0.0;    // mean (r - t)^2, for the PSNR a step reports
  double total = 0.0;  // the weighted loss above
};

// Scratch of ComputePhotometricLoss, one per thread (rings of a few
// rows), reused between calls (a fit's every step) so that a step does not
// allocate.
struct PhotometricLossBuffers {
  std::vector<std::vector<double>> threads;
};

// The loss, and dL/dr into `d_rendered` (resized to r's size) when it is
// not null. Computed in double, rows in parallel; the result does not
// depend on the thread count (sums are reduced row by row, in order).
// Throws pano4d::Error for mismatched sizes or a non-finite input value.
PhotometricLoss ComputePhotometricLoss(
    const std::vector<float>& rendered, const std::vector<float>& target,
    int width, int height, double ssim_weight = kDefaultSsimWeight,
    std::vector<float>* d_rendered = nullptr,
    PhotometricLossBuffers* buffers = nullptr);

// The depth term: mean |rendered - given| over the pixels with a given
// depth (> 0), divided by the view's median depth so that a weight means
// the same at any scene scale, times `weight`. Returns it, and writes its
// gradient into `d_depth` (the image's size; 0 where no depth is given).
// `median` and the count of given pixels must be positive.
double DepthL1Loss(const std::vector<float>& rendered,
                   const std::vector<float>& given, float median, double weight,
                   std::vector<float>* d_depth);

// The anisotropy term on log scales (rows of 3): `norm` x (ratio - bound)
// for each Gaussian whose largest scale is over `bound` times its
// smallest (ratio = largest / smallest), with its gradient added to
// `d_log_scales` (largest and smallest only). Rows in parallel, summed in
// a fixed order: the result does not depend on the thread count.
double AnisotropyLoss(const std::vector<float>& log_scales, double bound,
                      double norm, std::vector<float>* d_log_scales);

}  // namespace pano4d
