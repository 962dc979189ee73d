#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "src/render/rasterizer.h"

namespace pano4d {

// The pixels of a tile that a projected Gaussian can reach, i.e. where
// alpha >= kMinAlpha could hold: the rows of its box, and in each row the
// span of the ellipse q = a dx^2 + 2 b dx dy + c dy^2 <= 2 ln(o / kMinAlpha)
// (slightly inflated against rounding). The blend's forward and backward
// both walk exactly these (Gaussian, pixel) pairs.
template <typename T>
class GaussianSpan {
 public:
  GaussianSpan(const ProjectedGaussiansT<T>& p, std::uint32_t g, int x_begin,
               int x_end, int y_begin, int y_end)
      : gx_(p.x[g]),
        gy_(p.y[g]),
        a_(p.conic_a[g]),
        b_(p.conic_b[g]),
        c_(p.conic_c[g]) {
    // Pixels whose centre (px + 0.5) lies within the box.
    x0_ = std::max(x_begin,
                   static_cast<int>(std::ceil(gx_ - p.extent_x[g] - T(0.5))));
    x1_ = std::min(x_end - 1,
                   static_cast<int>(std::floor(gx_ + p.extent_x[g] - T(0.5))));
    y0_ = std::max(y_begin,
                   static_cast<int>(std::ceil(gy_ - p.extent_y[g] - T(0.5))));
    y1_ = std::min(y_end - 1,
                   static_cast<int>(std::floor(gy_ + p.extent_y[g] - T(0.5))));
    kq_ =
        T(2) * std::log(p.opacity[g] / T(kMinAlpha)) * (1 + T(1e-4)) + T(1e-4);
  }
  int first_row() const { return y0_; }
  int last_row() const { return y1_; }

  // Columns [*x0, *x1] of row `py`; false when the row holds none.
  bool Row(int py, int* x0, int* x1) const {
    const T dy = py + T(0.5) - gy_;
    const T half_b = b_ * dy;
    const T discriminant = half_b * half_b - a_ * (c_ * dy * dy - kq_);
    if (!(discriminant >= 0)) return false;
    const T root = std::sqrt(discriminant);
    *x0 =
        std::max(x0_, static_cast<int>(std::ceil(gx_ + (-half_b - root) / a_ -
                                                 T(0.5) - T(kAlphaBoxMargin))));
    *x1 = std::min(
        x1_, static_cast<int>(std::floor(gx_ + (-half_b + root) / a_ - T(0.5) +
                                         T(kAlphaBoxMargin))));
    return *x0 <= *x1;
  }

 private:
  T gx_, gy_, a_, b_, c_, kq_;
  int x0_, x1_, y0_, y1_;
};

}  // namespace pano4d
