#include "src/datasets/synth_texture.h"

#include <algorithm>
#include <cmath>

namespace pano4d::synth {
namespace {

// A 32-bit integer hash (lowbias32), avalanche-mixed, for lattice values.
std::uint32_t Hash(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

double Lattice(std::int64_t i, std::int64_t j, std::int64_t k,
               std::uint32_t seed) {
  std::uint32_t h = Hash(seed ^ 0x9e3779b9U);
  h = Hash(h ^ static_cast<std::uint32_t>(i));
  h = Hash(h ^ static_cast<std::uint32_t>(j));
  h = Hash(h ^ static_cast<std::uint32_t>(k));
  return h * (1.0 / 4294967295.0);
}

double Fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
double Lerp(double a, double b, double t) { return a + (b - a) * t; }

}  // namespace

double ValueNoise(const Eigen::Vector3d& p, std::uint32_t seed) {
  const double fx = std::floor(p.x()), fy = std::floor(p.y()),
               fz = std::floor(p.z());
  const auto i = static_cast<std::int64_t>(fx),
             j = static_cast<std::int64_t>(fy),
             k = static_cast<std::int64_t>(fz);
  const double u = Fade(p.x() - fx), v = Fade(p.y() - fy), w = Fade(p.z() - fz);
  const auto plane = [&](std::int64_t kk) {
    return Lerp(
        Lerp(Lattice(i, j, kk, seed), Lattice(i + 1, j, kk, seed), u),
        Lerp(Lattice(i, j + 1, kk, seed), Lattice(i + 1, j + 1, kk, seed), u),
        v);
  };
  return Lerp(plane(k), plane(k + 1), w);
}

double FractalNoise(const Eigen::Vector3d& p, int octaves, std::uint32_t seed) {
  double sum = 0, amplitude = 1, total = 0;
  Eigen::Vector3d q = p;
  for (int o = 0; o < octaves; ++o) {
    sum += amplitude * ValueNoise(q, seed + 101 * o);
    total += amplitude;
    amplitude *= 0.5;
    q = 2.0 * q +
        Eigen::Vector3d(17.1, -9.3, 4.7);  // shift so octaves do not align
  }
  return sum / total;
}

Eigen::Vector3d Albedo(const Material& m, const Eigen::Vector3d& p) {
  const double n = FractalNoise(p * m.frequency, 5, m.seed);
  Eigen::Vector3d color =
      m.color_a + (m.color_b - m.color_a) * std::clamp(1.6 * n - 0.3, 0.0, 1.0);
  if (m.pattern == 1) {
    const double stripe = std::sin(p.x() * 9.0 + p.z() * 4.0 + 3.0 * n);
    color *= stripe > 0.6 ? 0.55 : 1.0;
  } else if (m.pattern == 2) {
    const auto cell = [](double x) {
      return static_cast<std::int64_t>(std::floor(x * 3.0));
    };
    if ((cell(p.x()) + cell(p.y()) + cell(p.z())) % 2 != 0) color *= 0.7;
  }
  // Marks: at most one disc per lattice cell, of random size, placement and
  // tone; sharp-edged blobs that give SIFT stable corners and extrema.
  const Eigen::Vector3d c = p * m.mark_frequency;
  const Eigen::Vector3d cell(std::floor(c.x()), std::floor(c.y()),
                             std::floor(c.z()));
  const auto ci = cell.cast<std::int64_t>();
  const std::uint32_t mseed = m.seed * 7919U + 13U;
  if (Lattice(ci.x(), ci.y(), ci.z(), mseed) < m.mark_density) {
    const Eigen::Vector3d center(Lattice(ci.x(), ci.y(), ci.z(), mseed + 1),
                                 Lattice(ci.x(), ci.y(), ci.z(), mseed + 2),
                                 Lattice(ci.x(), ci.y(), ci.z(), mseed + 3));
    const double radius =
        0.12 + 0.25 * Lattice(ci.x(), ci.y(), ci.z(), mseed + 4);
    if ((c - cell - center).norm() < radius) {
      const double tone = Lattice(ci.x(), ci.y(), ci.z(), mseed + 5);
      color = tone < 0.5
                  ? m.mark_color
                  : Eigen::Vector3d(0.95, 0.93, 0.88) * (0.8 + 0.4 * tone);
    }
  }
  return color.cwiseMax(0.0).cwiseMin(1.0);
}

}  // namespace pano4d::synth
