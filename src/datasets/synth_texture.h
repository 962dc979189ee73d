#pragma once

#include <cstdint>

#include <Eigen/Core>

namespace pano4d::synth {

// Procedural solid textures for the synthetic scenes: deterministic functions
// of a 3D point in an object's own frame (so texture moves with the object)
// and a seed. Rich at several scales so that SIFT finds and matches features.

// Lattice value noise in [0, 1], smooth (quintic interpolation).
double ValueNoise(const Eigen::Vector3d& p, std::uint32_t seed);

// Fractal sum of `octaves` value-noise layers, frequency doubling and
// amplitude halving per octave, normalised to [0, 1].
double FractalNoise(const Eigen::Vector3d& p, int octaves, std::uint32_t seed);

struct Material {
  Eigen::Vector3d color_a = Eigen::Vector3d(0.6, 0.6, 0.6);
  Eigen::Vector3d color_b = Eigen::Vector3d(0.3, 0.3, 0.3);
  Eigen::Vector3d mark_color = Eigen::Vector3d(0.05, 0.05, 0.05);
  double frequency = 2.0;       // of the base noise, per metre
  double mark_frequency = 6.0;  // cells per metre of the mark layer
  double mark_density = 0.35;   // fraction of cells that hold a mark
  int pattern = 0;              // 0 noise only, 1 stripes, 2 checks
  std::uint32_t seed = 1;
};

// Albedo in [0, 1] at a point of the object (object frame, metres).
Eigen::Vector3d Albedo(const Material& material, const Eigen::Vector3d& p);

}  // namespace pano4d::synth
