#include "src/gs/appearance.h"

#include <algorithm>
#include <array>
#include <cstddef>

namespace pano4d {

std::vector<float> IdentityAppearance() {
  return {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
}

void ApplyAppearance(const float* a, const std::vector<float>& rgb,
                     std::vector<float>* out) {
  out->resize(rgb.size());
  const float* b = a + 9;
  const std::ptrdiff_t pixels = static_cast<std::ptrdiff_t>(rgb.size() / 3);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < pixels; ++i) {
    const std::size_t p = 3 * static_cast<std::size_t>(i);
    const float r = rgb[p], g = rgb[p + 1], bl = rgb[p + 2];
    for (int c = 0; c < 3; ++c)
      (*out)[p + c] =
          a[c * 3] * r + a[c * 3 + 1] * g + a[c * 3 + 2] * bl + b[c];
  }
}

void ApplyAppearanceBackward(const float* a, const std::vector<float>& rgb,
                             const std::vector<float>& d_out,
                             std::vector<float>* d_rgb, float* d_transform) {
  d_rgb->resize(rgb.size());
  // Pixels in blocks of a fixed size, in parallel; the blocks' sums are
  // added in order, so the result does not depend on the thread count.
  constexpr std::size_t kBlock = 4096;
  const std::size_t pixels = rgb.size() / 3;
  const std::ptrdiff_t blocks =
      static_cast<std::ptrdiff_t>((pixels + kBlock - 1) / kBlock);
  std::vector<std::array<double, 12>> block_sums(blocks);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < blocks; ++k) {
    std::array<double, 12>& sums = block_sums[k];
    sums.fill(0.0);
    const std::size_t end = std::min(pixels, (k + 1) * kBlock);
    for (std::size_t i = k * kBlock; i < end; ++i) {
      const std::size_t p = 3 * i;
      const float* g = &d_out[p];
      for (int j = 0; j < 3; ++j)
        (*d_rgb)[p + j] = a[j] * g[0] + a[3 + j] * g[1] + a[6 + j] * g[2];
      for (int c = 0; c < 3; ++c) {
        for (int j = 0; j < 3; ++j)
          sums[c * 3 + j] += double(g[c]) * rgb[p + j];
        sums[9 + c] += g[c];
      }
    }
  }
  double sums[12] = {0};
  for (const std::array<double, 12>& block : block_sums)
    for (int j = 0; j < 12; ++j) sums[j] += block[j];
  for (int k = 0; k < 12; ++k) d_transform[k] += static_cast<float>(sums[k]);
}

double AppearanceRegulariser(const float* a, double weight,
                             float* d_transform) {
  double sum = 0;
  for (int k = 0; k < kAppearanceWidth; ++k) {
    // The identity: ones on the 3 x 3 matrix's diagonal (k = 0, 4, 8).
    const double identity = (k < 9 && k % 4 == 0) ? 1.0 : 0.0;
    const double e = double(a[k]) - identity;
    sum += e * e;
    d_transform[k] += static_cast<float>(2.0 * weight * e);
  }
  return weight * sum;
}

}  // namespace pano4d
