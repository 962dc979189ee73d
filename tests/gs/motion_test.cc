#include "src/gs/motion.h"

#include <cmath>
#include <functional>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace pano4d {
namespace {

struct Problem {
  GaussianModelT<double> canonical;
  std::vector<double> logits;
  MotionBasesT<double> bases;
};

Problem RandomProblem(int n, int k, int times, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  Problem p;
  p.canonical.Resize(n);
  for (double& v : p.canonical.means) v = normal(rng);
  for (double& v : p.canonical.quats) v = normal(rng);
  p.logits.resize(n * k);
  for (double& v : p.logits) v = normal(rng);
  p.bases.Reset(k, times);
  // Rotations near the identity (as after initialisation), not unit length.
  for (std::size_t i = 0; i < p.bases.rotations.size(); ++i)
    p.bases.rotations[i] += 0.3 * normal(rng);
  for (double& v : p.bases.translations) v = normal(rng);
  return p;
}

// L = sum of g . posed means + h . posed quats, for random g and h.
struct Upstream {
  std::vector<double> means, quats;
};

double Loss(const Problem& p, int time, const Upstream& up) {
  GaussianModelT<double> posed;
  posed.Resize(p.canonical.size() + 2);
  PoseDynamicGaussians(p.canonical, p.logits, p.bases, time, 2, &posed);
  double loss = 0;
  for (std::size_t i = 6; i < posed.means.size(); ++i)
    loss += up.means[i] * posed.means[i];
  for (std::size_t i = 8; i < posed.quats.size(); ++i)
    loss += up.quats[i] * posed.quats[i];
  return loss;
}

void ExpectMatchesFiniteDifferences(std::vector<double>* params,
                                    const std::vector<double>& analytic,
                                    const std::function<double()>& loss,
                                    const char* what) {
  constexpr double kStep = 1e-6;
  for (std::size_t i = 0; i < params->size(); ++i) {
    const double saved = (*params)[i];
    (*params)[i] = saved + kStep;
    const double plus = loss();
    (*params)[i] = saved - kStep;
    const double minus = loss();
    (*params)[i] = saved;
    const double numeric = (plus - minus) / (2 * kStep);
    EXPECT_NEAR(analytic[i], numeric, 1e-6 * std::max(1.0, std::abs(numeric)))
        << what << "[" << i << "]";
  }
}

TEST(MotionTest, GradientsMatchFiniteDifferences) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const int n = 7, k = 3, times = 4, time = 2;
    Problem p = RandomProblem(n, k, times, seed);
    std::mt19937 rng(seed + 100);
    std::normal_distribution<double> normal;
    Upstream up;
    up.means.resize((n + 2) * 3);
    up.quats.resize((n + 2) * 4);
    for (double& v : up.means) v = normal(rng);
    for (double& v : up.quats) v = normal(rng);

    std::vector<double> d_means(n * 3), d_quats(n * 4), d_logits(n * k);
    MotionBasesT<double> d_bases;
    d_bases.Reset(k, times);
    std::fill(d_bases.rotations.begin(), d_bases.rotations.end(), 0.0);
    PoseDynamicGaussiansBackward(p.canonical, p.logits, p.bases, time, 2,
                                 up.means, up.quats, &d_means, &d_quats,
                                 &d_logits, &d_bases);
    const auto loss = [&] { return Loss(p, time, up); };
    ExpectMatchesFiniteDifferences(&p.canonical.means, d_means, loss, "mean");
    ExpectMatchesFiniteDifferences(&p.canonical.quats, d_quats, loss, "quat");
    ExpectMatchesFiniteDifferences(&p.logits, d_logits, loss, "logit");
    ExpectMatchesFiniteDifferences(&p.bases.rotations, d_bases.rotations, loss,
                                   "basis rotation");
    ExpectMatchesFiniteDifferences(&p.bases.translations, d_bases.translations,
                                   loss, "basis translation");
  }
}

TEST(MotionTest, IdentityBasesLeaveTheCanonicalGaussians) {
  Problem p = RandomProblem(5, 4, 3, 7);
  p.bases.Reset(4, 3);
  GaussianModelT<double> posed;
  posed.Resize(5);
  PoseDynamicGaussians(p.canonical, p.logits, p.bases, 1, 0, &posed);
  for (std::size_t i = 0; i < posed.means.size(); ++i)
    EXPECT_NEAR(posed.means[i], p.canonical.means[i], 1e-12);
  for (std::size_t i = 0; i < posed.quats.size(); ++i)
    EXPECT_NEAR(posed.quats[i], p.canonical.quats[i], 1e-12);
}

TEST(MotionTest, OneDominantBasisMovesRigidly) {
  // A Gaussian whose weight is all on basis 1 moves with that basis' pose:
  // mu = R mu_c + tau, q = q_1 (x) q_c.
  Problem p = RandomProblem(1, 2, 2, 3);
  p.logits = {-60.0, 60.0};
  const Eigen::Quaterniond rotation(
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  // Not unit length: blending normalises the rotation of the mean.
  const double scale = 1.7;
  double* r = p.bases.rotation(1, 1);
  r[0] = scale * rotation.w();
  r[1] = scale * rotation.x();
  r[2] = scale * rotation.y();
  r[3] = scale * rotation.z();
  double* t = p.bases.translation(1, 1);
  t[0] = 0.5, t[1] = -1, t[2] = 2;
  GaussianModelT<double> posed;
  posed.Resize(1);
  PoseDynamicGaussians(p.canonical, p.logits, p.bases, 1, 0, &posed);
  const Eigen::Vector3d mu(p.canonical.means[0], p.canonical.means[1],
                           p.canonical.means[2]);
  const Eigen::Vector3d expected = rotation * mu + Eigen::Vector3d(0.5, -1, 2);
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(posed.means[j], expected[j], 1e-9);
  const Eigen::Quaterniond qc(p.canonical.quats[0], p.canonical.quats[1],
                              p.canonical.quats[2], p.canonical.quats[3]);
  const Eigen::Quaterniond q = rotation * qc;
  EXPECT_NEAR(posed.quats[0], scale * q.w(), 1e-9);
  EXPECT_NEAR(posed.quats[1], scale * q.x(), 1e-9);
  EXPECT_NEAR(posed.quats[2], scale * q.y(), 1e-9);
  EXPECT_NEAR(posed.quats[3], scale * q.z(), 1e-9);
}

TEST(MotionTest, CancellingBasesGiveTheIdentityNotNaN) {
  // Two bases at opposite quaternions with equal weight blend to zero.
  Problem p = RandomProblem(1, 2, 1, 5);
  p.logits = {0.0, 0.0};
  double* r = p.bases.rotation(1, 0);
  r[0] = -1, r[1] = r[2] = r[3] = 0;
  p.bases.rotation(0, 0)[0] = 1;
  std::fill(p.bases.rotation(0, 0) + 1, p.bases.rotation(0, 0) + 4, 0.0);
  GaussianModelT<double> posed;
  posed.Resize(1);
  PoseDynamicGaussians(p.canonical, p.logits, p.bases, 0, 0, &posed);
  for (double v : posed.means) EXPECT_TRUE(std::isfinite(v));
  std::vector<double> up_m(3, 1.0), up_q(4, 1.0), dm(3), dq(4), dl(2);
  MotionBasesT<double> db = p.bases;
  PoseDynamicGaussiansBackward(p.canonical, p.logits, p.bases, 0, 0, up_m, up_q,
                               &dm, &dq, &dl, &db);
  for (double v : dm) EXPECT_TRUE(std::isfinite(v));
  for (double v : dl) EXPECT_TRUE(std::isfinite(v));
}

TEST(MotionTest, SmoothnessGradientMatchesFiniteDifferences) {
  Problem p = RandomProblem(1, 2, 5, 9);
  MotionBasesT<double> grad;
  grad.Reset(2, 5);
  std::fill(grad.rotations.begin(), grad.rotations.end(), 0.0);
  MotionSmoothnessLoss(p.bases, 0.3, &grad, 2.5);
  const auto loss = [&] {
    MotionBasesT<double> scratch = grad;
    return MotionSmoothnessLoss(p.bases, 0.3, &scratch, 2.5);
  };
  ExpectMatchesFiniteDifferences(&p.bases.translations, grad.translations, loss,
                                 "translation");
  ExpectMatchesFiniteDifferences(&p.bases.rotations, grad.rotations, loss,
                                 "rotation");
}

TEST(MotionTest, SmoothnessIsZeroForConstantVelocity) {
  MotionBasesT<double> bases;
  bases.Reset(1, 6);
  for (int t = 0; t < 6; ++t) bases.translation(0, t)[0] = 0.25 * t;
  MotionBasesT<double> grad = bases;
  EXPECT_NEAR(MotionSmoothnessLoss(bases, 1.0, &grad), 0.0, 1e-20);
}

}  // namespace
}  // namespace pano4d
