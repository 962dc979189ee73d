#include "src/gs/motion.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "src/core/error.h"

namespace pano4d {
namespace {

// Gaussians per block of the deterministic reduction of basis gradients.
constexpr std::size_t kBlock = 256;

template <typename T>
using Vec3 = std::array<T, 3>;
template <typename T>
using Quat = std::array<T, 4>;

// (w, x, y, z) quaternion product a (x) b.
template <typename T>
Quat<T> Multiply(const Quat<T>& a, const Quat<T>& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
          a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
          a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

// M(q) p, where M(q) / |q|^2 is the rotation of the quaternion q.
template <typename T>
Vec3<T> RotateUnnormalised(const Quat<T>& q, const Vec3<T>& p) {
  const T w = q[0], x = q[1], y = q[2], z = q[3];
  return {(w * w + x * x - y * y - z * z) * p[0] + 2 * (x * y - w * z) * p[1] +
              2 * (x * z + w * y) * p[2],
          2 * (x * y + w * z) * p[0] + (w * w - x * x + y * y - z * z) * p[1] +
              2 * (y * z - w * x) * p[2],
          2 * (x * z - w * y) * p[0] + 2 * (y * z + w * x) * p[1] +
              (w * w - x * x - y * y + z * z) * p[2]};
}

// Rotates with the transposed rotation: R(q)^T g for a unit-scaled M.
template <typename T>
Vec3<T> RotateTransposedUnnormalised(const Quat<T>& q, const Vec3<T>& g) {
  return RotateUnnormalised<T>({q[0], -q[1], -q[2], -q[3]}, g);
}

template <typename T>
struct Blend {
  Quat<T> q{};  // blended rotation
  Vec3<T> t{};  // blended translation
  T norm2 = 0;  // |q|^2, 0 when replaced by the identity
  bool identity = false;
};

template <typename T>
void Softmax(const T* logits, int k, T* w) {
  T max = logits[0];
  for (int i = 1; i < k; ++i) max = std::max(max, logits[i]);
  T sum = 0;
  for (int i = 0; i < k; ++i) {
    w[i] = std::exp(logits[i] - max);
    sum += w[i];
  }
  for (int i = 0; i < k; ++i) w[i] /= sum;
}

template <typename T>
Blend<T> BlendBases(const MotionBasesT<T>& bases, int time, const T* w) {
  Blend<T> b;
  for (int k = 0; k < bases.num_bases; ++k) {
    const T* r = bases.rotation(k, time);
    const T* tr = bases.translation(k, time);
    for (int j = 0; j < 4; ++j) b.q[j] += w[k] * r[j];
    for (int j = 0; j < 3; ++j) b.t[j] += w[k] * tr[j];
  }
  b.norm2 =
      b.q[0] * b.q[0] + b.q[1] * b.q[1] + b.q[2] * b.q[2] + b.q[3] * b.q[3];
  if (!(b.norm2 >= T(kMinBlendedQuaternionNorm * kMinBlendedQuaternionNorm))) {
    b.q = {1, 0, 0, 0};
    b.norm2 = 1;
    b.identity = true;
  }
  return b;
}

}  // namespace

template <typename T>
void MotionBasesT<T>::Reset(int bases, int times) {
  num_bases = bases;
  num_times = times;
  rotations.assign(static_cast<std::size_t>(bases) * times * 4, T(0));
  translations.assign(static_cast<std::size_t>(bases) * times * 3, T(0));
  for (std::size_t i = 0; i < rotations.size(); i += 4) rotations[i] = 1;
}

template <typename T>
void MotionBasesT<T>::Check() const {
  const std::size_t kt = static_cast<std::size_t>(std::max(num_bases, 0)) *
                         static_cast<std::size_t>(std::max(num_times, 0));
  if (num_bases < 0 || num_times < 0 || rotations.size() != kt * 4 ||
      translations.size() != kt * 3) {
    throw Error("motion bases", "sizes",
                std::to_string(rotations.size()) + ", " +
                    std::to_string(translations.size()),
                "expected " + std::to_string(num_bases) + " bases x " +
                    std::to_string(num_times) + " times x 4 and x 3");
  }
}

template <typename T>
void PoseDynamicGaussians(const GaussianModelT<T>& canonical,
                          const std::vector<T>& logits,
                          const MotionBasesT<T>& bases, int time,
                          std::size_t offset, GaussianModelT<T>* posed) {
  const std::size_t n = canonical.size();
  const int k = bases.num_bases;
  if (logits.size() != n * k || time < 0 || time >= bases.num_times ||
      posed->means.size() < (offset + n) * 3 ||
      posed->quats.size() < (offset + n) * 4) {
    throw Error("dynamic Gaussians", "time", std::to_string(time),
                "logits, bases or output do not match " + std::to_string(n) +
                    " Gaussians and " + std::to_string(bases.num_times) +
                    " times");
  }
#pragma omp parallel
  {
    std::vector<T> w(k);
#pragma omp for schedule(static)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
      Softmax(&logits[i * k], k, w.data());
      const Blend<T> b = BlendBases(bases, time, w.data());
      const Vec3<T> mu = {canonical.means[i * 3], canonical.means[i * 3 + 1],
                          canonical.means[i * 3 + 2]};
      const Vec3<T> v = RotateUnnormalised(b.q, mu);
      T* out_mean = &posed->means[(offset + i) * 3];
      for (int j = 0; j < 3; ++j) out_mean[j] = v[j] / b.norm2 + b.t[j];
      const Quat<T> qc = {canonical.quats[i * 4], canonical.quats[i * 4 + 1],
                          canonical.quats[i * 4 + 2],
                          canonical.quats[i * 4 + 3]};
      const Quat<T> q = Multiply(b.q, qc);
      std::copy(q.begin(), q.end(), &posed->quats[(offset + i) * 4]);
    }
  }
}

namespace {

// dL/dq_b, the blended (unnormalised) rotation's gradient, from the posed
// mean's gradient g and the posed rotation's gq: mu(t) = M(q_b) mu_c / s +
// t_b and q(t) = q_b (x) q_c. Zero for the identity blend.
template <typename T>
Quat<T> BlendedRotationGradient(const Blend<T>& b, const Vec3<T>& mu,
                                const Quat<T>& qc, const Vec3<T>& g,
                                const Quat<T>& gq) {
  Quat<T> gqb{};
  if (b.identity) return gqb;
  const T s = b.norm2;
  // d/dq_b of M(q_b) mu_c / s: (dM/dq_j mu_c - 2 q_j v) / s, v = M mu/s.
  const T qw = b.q[0], qx = b.q[1], qy = b.q[2], qz = b.q[3];
  const T px = mu[0], py = mu[1], pz = mu[2];
  const Vec3<T> mv = RotateUnnormalised(b.q, mu);
  const Vec3<T> v = {mv[0] / s, mv[1] / s, mv[2] / s};
  const std::array<Vec3<T>, 4> dm = {
      Vec3<T>{2 * (qw * px - qz * py + qy * pz),
              2 * (qz * px + qw * py - qx * pz),
              2 * (-qy * px + qx * py + qw * pz)},
      Vec3<T>{2 * (qx * px + qy * py + qz * pz),
              2 * (qy * px - qx * py - qw * pz),
              2 * (qz * px + qw * py - qx * pz)},
      Vec3<T>{2 * (-qy * px + qx * py + qw * pz),
              2 * (qx * px + qy * py + qz * pz),
              2 * (-qw * px + qz * py - qy * pz)},
      Vec3<T>{2 * (-qz * px - qw * py + qx * pz),
              2 * (qw * px - qz * py + qy * pz),
              2 * (qx * px + qy * py + qz * pz)}};
  for (int j = 0; j < 4; ++j) {
    T dot = 0;
    for (int c = 0; c < 3; ++c) dot += g[c] * (dm[j][c] - 2 * b.q[j] * v[c]);
    gqb[j] = dot / s;
  }
  // q(t) = q_b (x) q_c: d/dq_b.
  gqb[0] += gq[0] * qc[0] + gq[1] * qc[1] + gq[2] * qc[2] + gq[3] * qc[3];
  gqb[1] += -gq[0] * qc[1] + gq[1] * qc[0] - gq[2] * qc[3] + gq[3] * qc[2];
  gqb[2] += -gq[0] * qc[2] + gq[1] * qc[3] + gq[2] * qc[0] - gq[3] * qc[1];
  gqb[3] += -gq[0] * qc[3] - gq[1] * qc[2] + gq[2] * qc[1] + gq[3] * qc[0];
  return gqb;
}

// q(t) = q_b (x) q_c: d/dq_c, added to dqc[4].
template <typename T>
void AddCanonicalRotationGradient(const Quat<T>& a, const Quat<T>& gq, T* dqc) {
  dqc[0] += gq[0] * a[0] + gq[1] * a[1] + gq[2] * a[2] + gq[3] * a[3];
  dqc[1] += -gq[0] * a[1] + gq[1] * a[0] + gq[2] * a[3] - gq[3] * a[2];
  dqc[2] += -gq[0] * a[2] - gq[1] * a[3] + gq[2] * a[0] + gq[3] * a[1];
  dqc[3] += -gq[0] * a[3] + gq[1] * a[2] - gq[2] * a[1] + gq[3] * a[0];
}

// q_b = sum w_k q_k, t_b = sum w_k tau_k: each basis's gradient at `time`
// added to acc (K x 7), and dL/dw_k into dw.
template <typename T>
void AddBasisGradients(const MotionBasesT<T>& bases, int time, const T* w,
                       const Quat<T>& gqb, const Vec3<T>& g, T* acc, T* dw) {
  for (int kk = 0; kk < bases.num_bases; ++kk) {
    const T* r = bases.rotation(kk, time);
    const T* tr = bases.translation(kk, time);
    T* acc_k = acc + kk * 7;
    dw[kk] = 0;
    for (int j = 0; j < 4; ++j) {
      acc_k[j] += w[kk] * gqb[j];
      dw[kk] += r[j] * gqb[j];
    }
    for (int j = 0; j < 3; ++j) {
      acc_k[4 + j] += w[kk] * g[j];
      dw[kk] += tr[j] * g[j];
    }
  }
}

}  // namespace

template <typename T>
void PoseDynamicGaussiansBackward(
    const GaussianModelT<T>& canonical, const std::vector<T>& logits,
    const MotionBasesT<T>& bases, int time, std::size_t offset,
    const std::vector<T>& d_posed_means, const std::vector<T>& d_posed_quats,
    std::vector<T>* d_means, std::vector<T>* d_quats, std::vector<T>* d_logits,
    MotionBasesT<T>* d_bases) {
  const std::size_t n = canonical.size();
  const int k = bases.num_bases;
  if (d_posed_means.size() < (offset + n) * 3 ||
      d_posed_quats.size() < (offset + n) * 4 || d_means->size() != n * 3 ||
      d_quats->size() != n * 4 || d_logits->size() != n * k ||
      d_bases->rotations.size() != bases.rotations.size() ||
      d_bases->translations.size() != bases.translations.size()) {
    throw Error("dynamic Gaussians", "gradients", std::to_string(n),
                "gradient arrays are not sized like the model");
  }
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  // Per block: K x (4 rotation + 3 translation) basis gradients at `time`.
  std::vector<T> block_grads(blocks * k * 7, T(0));
#pragma omp parallel
  {
    std::vector<T> w(k), dw(k);
#pragma omp for schedule(static)
    for (std::ptrdiff_t blk = 0; blk < static_cast<std::ptrdiff_t>(blocks);
         ++blk) {
      T* acc = &block_grads[blk * k * 7];
      const std::size_t end =
          std::min(n, (static_cast<std::size_t>(blk) + 1) * kBlock);
      for (std::size_t i = static_cast<std::size_t>(blk) * kBlock; i < end;
           ++i) {
        Softmax(&logits[i * k], k, w.data());
        const Blend<T> b = BlendBases(bases, time, w.data());
        const Vec3<T> mu = {canonical.means[i * 3], canonical.means[i * 3 + 1],
                            canonical.means[i * 3 + 2]};
        const Quat<T> qc = {canonical.quats[i * 4], canonical.quats[i * 4 + 1],
                            canonical.quats[i * 4 + 2],
                            canonical.quats[i * 4 + 3]};
        const Vec3<T> g = {d_posed_means[(offset + i) * 3],
                           d_posed_means[(offset + i) * 3 + 1],
                           d_posed_means[(offset + i) * 3 + 2]};
        const Quat<T> gq = {d_posed_quats[(offset + i) * 4],
                            d_posed_quats[(offset + i) * 4 + 1],
                            d_posed_quats[(offset + i) * 4 + 2],
                            d_posed_quats[(offset + i) * 4 + 3]};
        const T s = b.norm2;

        // mu(t) = M(q_b) mu_c / s + t_b.
        const Vec3<T> gmu = RotateTransposedUnnormalised(b.q, g);
        for (int j = 0; j < 3; ++j) (*d_means)[i * 3 + j] += gmu[j] / s;

        const Quat<T> gqb = BlendedRotationGradient(b, mu, qc, g, gq);
        AddCanonicalRotationGradient(b.q, gq, &(*d_quats)[i * 4]);
        AddBasisGradients(bases, time, w.data(), gqb, g, acc, dw.data());
        // Softmax: d logit_j = w_j (dw_j - sum_k w_k dw_k).
        T mean = 0;
        for (int kk = 0; kk < k; ++kk) mean += w[kk] * dw[kk];
        for (int kk = 0; kk < k; ++kk)
          (*d_logits)[i * k + kk] += w[kk] * (dw[kk] - mean);
      }
    }
  }
  for (std::size_t blk = 0; blk < blocks; ++blk) {
    const T* acc = &block_grads[blk * k * 7];
    for (int kk = 0; kk < k; ++kk) {
      T* dr = d_bases->rotation(kk, time);
      T* dt = d_bases->translation(kk, time);
      for (int j = 0; j < 4; ++j) dr[j] += acc[kk * 7 + j];
      for (int j = 0; j < 3; ++j) dt[j] += acc[kk * 7 + 4 + j];
    }
  }
}

template <typename T>
double MotionSmoothnessLoss(const MotionBasesT<T>& bases, double weight,
                            MotionBasesT<T>* d_bases,
                            double translation_scale) {
  double loss = 0;
  // A mean over every (basis, time, component) second difference, so that
  // the weight does not depend on K or the number of frames.
  const std::size_t terms =
      static_cast<std::size_t>(bases.num_bases) *
      static_cast<std::size_t>(std::max(0, bases.num_times - 2)) * 7;
  if (terms == 0) return 0.0;
  weight /= static_cast<double>(terms);
  auto second_difference = [&](std::vector<T>& grads,
                               const std::vector<T>& values, int width,
                               double scale) {
    for (int k = 0; k < bases.num_bases; ++k) {
      for (int t = 1; t + 1 < bases.num_times; ++t) {
        const std::size_t base = static_cast<std::size_t>(k) * bases.num_times;
        for (int j = 0; j < width; ++j) {
          const T a = values[(base + t - 1) * width + j];
          const T b = values[(base + t) * width + j];
          const T c = values[(base + t + 1) * width + j];
          const double d = (static_cast<double>(a) - 2.0 * b + c) / scale;
          loss += weight * d * d;
          const T g = static_cast<T>(2.0 * weight * d / scale);
          grads[(base + t - 1) * width + j] += g;
          grads[(base + t) * width + j] -= 2 * g;
          grads[(base + t + 1) * width + j] += g;
        }
      }
    }
  };
  second_difference(d_bases->translations, bases.translations, 3,
                    translation_scale);
  second_difference(d_bases->rotations, bases.rotations, 4, 1.0);
  return loss;
}

#define PANO4D_INSTANTIATE(T)                                                  \
  template struct MotionBasesT<T>;                                             \
  template void PoseDynamicGaussians<T>(                                       \
      const GaussianModelT<T>&, const std::vector<T>&, const MotionBasesT<T>&, \
      int, std::size_t, GaussianModelT<T>*);                                   \
  template void PoseDynamicGaussiansBackward<T>(                               \
      const GaussianModelT<T>&, const std::vector<T>&, const MotionBasesT<T>&, \
      int, std::size_t, const std::vector<T>&, const std::vector<T>&,          \
      std::vector<T>*, std::vector<T>*, std::vector<T>*, MotionBasesT<T>*);    \
  template double MotionSmoothnessLoss<T>(const MotionBasesT<T>&, double,      \
                                          MotionBasesT<T>*, double);
PANO4D_INSTANTIATE(float)
PANO4D_INSTANTIATE(double)
#undef PANO4D_INSTANTIATE

}  // namespace pano4d
