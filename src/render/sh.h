#pragma once

#include <Eigen/Core>

namespace pano4d {

// Real spherical harmonics of degree 0..3 as 3D Gaussian splatting uses them
// (the constants and sign conventions of its reference implementation):
// colour = max(0, sum_k basis_k(dir) * coeff_k + 0.5), per channel.

// The degree-0 basis value: colour = kShC0 * dc + 0.5 for a degree-0
// Gaussian (float code converts it: static_cast<float>(kShC0)).
inline constexpr double kShC0 = 0.28209479177387814;

// The K = (degree + 1)^2 basis values for a unit direction.
template <typename T>
void ShBasis(int degree, const Eigen::Matrix<T, 3, 1>& dir, T* basis);

// d basis_k / d dir for the K basis functions (K x 3, row-major), treating
// dir's components as free (the caller applies the normalisation).
template <typename T>
void ShBasisGradient(int degree, const Eigen::Matrix<T, 3, 1>& dir, T* d_basis);

// Colour from `coeffs` (K x 3, coefficient-major) seen along `dir` (unit,
// from the camera centre to the Gaussian). `clamped` (optional, 3) records
// which channels hit the max(0, .) clamp, for the backward pass.
template <typename T>
Eigen::Matrix<T, 3, 1> ShColor(int degree, const T* coeffs,
                               const Eigen::Matrix<T, 3, 1>& dir,
                               bool* clamped = nullptr);

// ShColor's backward: d_color (3; zero for a channel the clamp held at 0)
// -> d_coeffs (K x 3, written), and the returned gradient with respect to
// the unnormalised view vector (the Gaussian's mean minus the camera
// centre) that ShColor's direction was normalised from.
template <typename T>
Eigen::Matrix<T, 3, 1> ShColorVjp(int degree, const T* coeffs,
                                  const Eigen::Matrix<T, 3, 1>& view,
                                  const T* d_color, T* d_coeffs);

}  // namespace pano4d
