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

}  // namespace pano4d
