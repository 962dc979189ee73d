#pragma once
// The per-pixel arithmetic of the blend, shared by its forward and backward
// so that both see exactly the same alpha for every (Gaussian, pixel) pair.
// Written as branch-free lane loops over a tile row (kTileSize pixels) so
// that the compiler vectorises them: a pair either contributes (alpha > 0)
// or not, and masks select what each lane keeps.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include "src/render/rasterizer.h"

namespace pano4d {

// a * b + c, fused where the target has FMA. The render library is built
// with -ffp-contract=off, so the compiler never fuses on its own: the blend's
// forward and backward, written with this, round identically, whatever the
// surrounding code (contraction would depend on it).
template <typename T>
inline T MulAdd(T a, T b, T c) {
#if defined(__FMA__)
  return std::fma(a, b, c);
#else
  return a * b + c;
#endif
}

// exp(x) for x <= 0 in float, vectorisable: Cephes' expf (range reduction
// to |r| <= ln2 / 2, degree-6 polynomial, the power of two assembled in the
// exponent bits); relative error about 2 ulp. Arguments below
// kExpFloor give exp(kExpFloor), about 1e-38 (float's smallest normal is
// 1.2e-38): alpha there is 0 after the kMinAlpha test anyway.
inline constexpr float kExpFloor = -87.0f;
inline float ExpNonPositive(float x) {
  x = std::max(x, kExpFloor);
  // Round x / ln2 to the nearest integer n with the 1.5 * 2^23 trick: the
  // sum's low mantissa bits hold n (no float-to-int conversion needed).
  constexpr float kRound = 12582912.0f;
  const float shifted = MulAdd(x, 1.44269504088896341f, kRound);
  const float n = shifted - kRound;
  // r = x - n ln2, with ln2 split so that n * 0.693359375 is exact.
  const float r = MulAdd(n, 2.12194440e-4f, MulAdd(n, -0.693359375f, x));
  float p = 1.9875691500e-4f;
  p = MulAdd(p, r, 1.3981999507e-3f);
  p = MulAdd(p, r, 8.3334519073e-3f);
  p = MulAdd(p, r, 4.1665795894e-2f);
  p = MulAdd(p, r, 1.6666665459e-1f);
  p = MulAdd(p, r, 5.0000001201e-1f);
  p = MulAdd(p, r * r, r + 1.0f);
  const std::int32_t scale =
      (std::bit_cast<std::int32_t>(shifted) - 0x4B400000 + 127) << 23;
  return p * std::bit_cast<float>(scale);
}
// Double is the precision of gradient checks: the library's exp.
inline double ExpNonPositive(double x) { return std::exp(x); }

// A Gaussian's exponent along one pixel row: power(dx) = -1/2 d^T conic d
// with d = (dx, dy), evaluated the same way in forward and backward.
template <typename T>
struct ConicRow {
  ConicRow(T a, T b, T c, T dy)
      : half_a(T(0.5) * a), b_dy(b * dy), row(-T(0.5) * c * dy * dy) {}
  T Power(T dx) const { return MulAdd(-dx, MulAdd(half_a, dx, b_dy), row); }
  T half_a, b_dy, row;
};

// What one (Gaussian, pixel) pair contributes. alpha is 0 when the pair
// does not contribute (alpha < kMinAlpha). The exponent is <= 0 for a
// positive-definite conic; rounding can push it a hair above 0 next to the
// mean, where it is clamped (exp stays 1) instead of dropping the pair.
template <typename T>
struct PixelAlpha {
  T gauss;  // exp(power)
  T raw;    // opacity * gauss, before the kMaxAlpha clamp
  T alpha;  // min(kMaxAlpha, raw), or 0
};
template <typename T>
inline PixelAlpha<T> EvaluateAlpha(const ConicRow<T>& row, T opacity, T dx) {
  const T gauss = ExpNonPositive(std::min(row.Power(dx), T(0)));
  const T raw = opacity * gauss;
  // raw >= kMinAlpha <=> min(kMaxAlpha, raw) >= kMinAlpha.
  return {gauss, raw, raw >= T(kMinAlpha) ? std::min(T(kMaxAlpha), raw) : T(0)};
}

// Tile `tile` of a width x height image in kTileSize tiles, row-major: its
// pixels [x_begin, x_end) x [y_begin, y_end) (clipped at the right and
// bottom edges) and the x of each lane's pixel centre. Forward and backward
// walk tiles through this, so they agree on every pixel.
template <typename T>
struct TileRect {
  TileRect(int tile, int tiles_x, int width, int height)
      : x_begin((tile % tiles_x) * kTileSize),
        y_begin((tile / tiles_x) * kTileSize),
        x_end(std::min(x_begin + kTileSize, width)),
        y_end(std::min(y_begin + kTileSize, height)) {
    for (int lane = 0; lane < kTileSize; ++lane)
      lane_x[lane] = x_begin + lane + T(0.5);
  }
  int x_begin, y_begin, x_end, y_end;
  alignas(64) T lane_x[kTileSize];
};

// Lanes are processed in groups of this many adjacent pixels: one or two
// SIMD vectors of floats, and fine-grained enough that a small Gaussian
// does not pay for the whole tile row.
inline constexpr int kLaneGroup = 8;
static_assert(kTileSize % kLaneGroup == 0);

// The part of a tile where a Gaussian can reach alpha >= kMinAlpha: the
// rows [y0, y1] and lane groups [group0, group1] whose pixel centres
// (p + 0.5) lie within its box (ProjectedGaussiansT::extent_x/_y).
// Forward and backward visit exactly these pixels.
struct TileBox {
  int y0, y1, group0, group1;
};
template <typename T>
inline bool BoxInTile(const ProjectedGaussiansT<T>& p, std::uint32_t g,
                      int x_begin, int x_end, int y_begin, int y_end,
                      TileBox* box) {
  // Clamped to the tile (one past it for an empty box) before the
  // conversion: a Gaussian far off screen or of enormous extent gives
  // values beyond int's range, whose conversion is undefined.
  const auto first = [](T v, int begin, int end) {
    return static_cast<int>(std::clamp(std::ceil(v), T(begin), T(end)));
  };
  const auto last = [](T v, int begin, int end) {
    return static_cast<int>(
        std::clamp(std::floor(v), T(begin - 1), T(end - 1)));
  };
  const int x0 = first(p.x[g] - p.extent_x[g] - T(0.5), x_begin, x_end);
  const int x1 = last(p.x[g] + p.extent_x[g] - T(0.5), x_begin, x_end);
  box->y0 = first(p.y[g] - p.extent_y[g] - T(0.5), y_begin, y_end);
  box->y1 = last(p.y[g] + p.extent_y[g] - T(0.5), y_begin, y_end);
  box->group0 = (x0 - x_begin) / kLaneGroup;
  box->group1 = (x1 - x_begin) / kLaneGroup;
  return x0 <= x1 && box->y0 <= box->y1;
}

}  // namespace pano4d
