#pragma once

#include <cstddef>
#include <vector>

#include "src/render/gaussians.h"

namespace pano4d {

// Motion of dynamic Gaussians (DESIGN.md "Dynamic Gaussians", after Shape of
// Motion): K rigid motion bases shared by all dynamic Gaussians, each a pose
// per frame, and per Gaussian the logits of softmax weights over the bases.
// At time t, with w = softmax(logits):
//   q_b = sum_k w_k q_k(t)          blended basis rotation (not normalised)
//   t_b = sum_k w_k tau_k(t)        blended basis translation
//   mu(t) = R(q_b / |q_b|) mu_c + t_b
//   q(t)  = q_b (x) q_c             (the rasterizer normalises quaternions)
// Shape of Motion blends 6D rotation vectors; pano4d blends quaternions,
// which keeps every derivative a short closed form. Blending is well posed
// because all bases start at the identity (one hemisphere).
template <typename T>
struct MotionBasesT {
  int num_bases = 0;
  int num_times = 0;
  std::vector<T> rotations;     // K x T x 4, (w, x, y, z), any non-zero norm
  std::vector<T> translations;  // K x T x 3, world units

  // K bases that are the identity at every time.
  void Reset(int bases, int times);
  T* rotation(int k, int t) { return &rotations[(k * num_times + t) * 4]; }
  const T* rotation(int k, int t) const {
    return &rotations[(k * num_times + t) * 4];
  }
  T* translation(int k, int t) {
    return &translations[(k * num_times + t) * 3];
  }
  const T* translation(int k, int t) const {
    return &translations[(k * num_times + t) * 3];
  }
  bool empty() const { return num_bases == 0; }
  // Throws pano4d::Error when the arrays disagree with the counts.
  void Check() const;
};

// A blended basis rotation shorter than this (bases pointing at opposite
// hemispheres cancel) is replaced by the identity, with no gradient, instead
// of dividing by (almost) zero.
inline constexpr double kMinBlendedQuaternionNorm = 1e-6;

// Poses the canonical dynamic Gaussians at `time`: writes rows
// [offset, offset + N) of `posed`'s means and quats (which must be sized);
// the other attributes are the caller's. `logits` is N x K.
template <typename T>
void PoseDynamicGaussians(const GaussianModelT<T>& canonical,
                          const std::vector<T>& logits,
                          const MotionBasesT<T>& bases, int time,
                          std::size_t offset, GaussianModelT<T>* posed);

// The backward of PoseDynamicGaussians: from the gradients of the posed
// means and quats (rows [offset, offset + N) of `d_posed_means`,
// `d_posed_quats`) to the canonical means and quats, the logits and the
// bases at `time`. Adds into the outputs, which must be sized (canonical
// N x 3 and N x 4, logits N x K, bases like `bases`). Sums over Gaussians
// are taken in fixed blocks in a fixed order, so results do not depend on
// the number of threads.
template <typename T>
void PoseDynamicGaussiansBackward(
    const GaussianModelT<T>& canonical, const std::vector<T>& logits,
    const MotionBasesT<T>& bases, int time, std::size_t offset,
    const std::vector<T>& d_posed_means, const std::vector<T>& d_posed_quats,
    std::vector<T>* d_means, std::vector<T>* d_quats, std::vector<T>* d_logits,
    MotionBasesT<T>* d_bases);

// Temporal smoothness of the bases: the mean over k, t and components of
// the squared second difference of translations (divided by
// `translation_scale`, e.g. the scene extent, so that the weight does not
// depend on the scene's units) and rotations (acceleration), times
// `weight`. Adds its gradient into `d_bases` and returns the value.
template <typename T>
double MotionSmoothnessLoss(const MotionBasesT<T>& bases, double weight,
                            MotionBasesT<T>* d_bases,
                            double translation_scale = 1.0);

using MotionBases = MotionBasesT<float>;

}  // namespace pano4d
