#pragma once

#include <cmath>
#include <limits>

namespace pano4d {

// PSNR in dB of a mean squared error between images in [0, 1]:
// -10 log10(mse), +inf for identical images. Every PSNR pano4d reports is
// this of some MSE: DyCheck's metrics on 8-bit quantised images
// (evaluation/metrics.h: fit.json, metrics.json, the benches) and the fit's
// per-step training PSNR on the float render (fit.csv).
inline double PsnrFromMse(double mse) {
  return mse > 0 ? -10.0 * std::log10(mse)
                 : std::numeric_limits<double>::infinity();
}

}  // namespace pano4d
