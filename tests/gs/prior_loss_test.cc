#include "src/gs/prior_loss.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "src/core/error.h"

namespace pano4d {
namespace {

constexpr int kWidth = 40, kHeight = 30;

RasterCameraT<double> CameraAt(double x) {
  RasterCameraT<double> c;
  c.width = kWidth;
  c.height = kHeight;
  c.fx = c.fy = 36;
  c.cx = kWidth / 2.0;
  c.cy = kHeight / 2.0;
  c.translation = Eigen::Vector3d(-x, 0, 0);  // centre at (x, 0, 0)
  return c;
}

// `n` Gaussians at depth about 3 in front of CameraAt(0), the first
// `statics` static; the rest also posed at the other time as `means_b`.
struct Scene {
  GaussianModelT<double> model;
  std::vector<double> means_b;
  std::size_t first = 0;
};

Scene MakeScene(int n, int statics, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-0.9, 0.9), dz(-0.02, 0.02),
      step(-0.1, 0.1);
  Scene s;
  s.first = statics;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p(xy(rng), 0.7 * xy(rng), 3.0 + dz(rng));
    for (int k = 0; k < 3; ++k) s.model.means.push_back(p(k));
    for (int k = 0; k < 3; ++k) s.model.log_scales.push_back(-3);
    for (double q : {1.0, 0.0, 0.0, 0.0}) s.model.quats.push_back(q);
    s.model.opacities.push_back(0);
    for (int k = 0; k < 3; ++k) s.model.sh.push_back(0);
    if (i >= statics)
      for (int k = 0; k < 3; ++k) s.means_b.push_back(p(k) + step(rng));
  }
  return s;
}

// A constant flow of (u, v) pixels, valid everywhere but the last column,
// and a rendered depth of 3 (the Gaussians' surface).
std::vector<float> Flow(float u, float v) {
  std::vector<float> flow;
  for (int p = 0; p < kWidth * kHeight; ++p) {
    flow.push_back(u);
    flow.push_back(v);
  }
  return flow;
}
std::vector<std::uint8_t> Valid() {
  std::vector<std::uint8_t> valid(kWidth * kHeight, 255);
  for (int y = 0; y < kHeight; ++y) valid[y * kWidth + kWidth - 1] = 0;
  return valid;
}
const std::vector<float> kSurface(kWidth * kHeight, 3.0f);

FlowTerm Evaluate(const Scene& s, std::vector<double>* da = nullptr,
                  std::vector<double>* db = nullptr, double huber = 2.0) {
  std::vector<double> a(s.model.size() * 3, 0.0), b(s.means_b.size(), 0.0);
  return FlowLoss(s.model, s.first, s.means_b, CameraAt(0), CameraAt(0.2),
                  Flow(-2.0f, 0.5f), Valid(), kSurface, 1.0, 0.05, huber,
                  da ? da : &a, db ? db : &b);
}

TEST(FlowLossTest, ZeroWhereTheGaussiansFollowTheFlow) {
  // A static point seen from a camera 0.2 to the right moves by -f 0.2 / z
  // = -2.4 px at z = 3: the flow of a static scene.
  Scene s = MakeScene(30, 0, 1);
  for (std::size_t i = 0; i < s.model.size(); ++i)
    for (int k = 0; k < 3; ++k) s.means_b[3 * i + k] = s.model.means[3 * i + k];
  std::vector<double> a(s.model.size() * 3, 0.0), b(s.means_b.size(), 0.0);
  const FlowTerm term =
      FlowLoss(s.model, 0, s.means_b, CameraAt(0), CameraAt(0.2),
               Flow(-36 * 0.2 / 3.0, 0), Valid(), kSurface, 1.0, 0.05, 2.0, &a,
               &b);
  EXPECT_GT(term.gaussians, 20);
  EXPECT_LT(term.mean_error, 0.2);  // the depths spread by 2%
  // Moved by a pixel's worth sideways at the other time: an error of 1 px.
  for (std::size_t i = 0; i < s.model.size(); ++i) s.means_b[3 * i] += 3.0 / 36;
  EXPECT_NEAR(FlowLoss(s.model, 0, s.means_b, CameraAt(0), CameraAt(0.2),
                       Flow(-36 * 0.2 / 3.0, 0), Valid(), kSurface, 1.0, 0.05,
                       2.0, &a, &b)
                  .mean_error,
              1.0, 0.2);
}

TEST(FlowLossTest, OnlyDynamicGaussiansOnTheSurfaceWithValidFlowCount) {
  Scene s = MakeScene(40, 10, 2);
  const FlowTerm all = Evaluate(s);
  EXPECT_GT(all.gaussians, 0);
  EXPECT_LE(all.gaussians, 30);  // rows below `first` are static
  // Pushed behind the rendered surface by more than the tolerance: gone.
  for (std::size_t i = s.first; i < s.model.size(); ++i)
    s.model.means[3 * i + 2] += 0.5;
  EXPECT_EQ(Evaluate(s).gaussians, 0);
}

TEST(FlowLossTest, GradientMatchesCentralDifferences) {
  for (const double huber : {2.0, 0.05}) {  // inside and outside the Huber
    const Scene s = MakeScene(12, 3, 3);
    std::vector<double> da(s.model.size() * 3, 0.0), db(s.means_b.size(), 0.0);
    const FlowTerm term = Evaluate(s, &da, &db, huber);
    ASSERT_GT(term.gaussians, 5);
    constexpr double kStep = 1e-6;
    for (std::size_t j = 0; j < s.model.means.size(); ++j) {
      Scene plus = s, minus = s;
      plus.model.means[j] += kStep;
      minus.model.means[j] -= kStep;
      const double numeric =
          (Evaluate(plus, nullptr, nullptr, huber).loss -
           Evaluate(minus, nullptr, nullptr, huber).loss) /
          (2 * kStep);
      EXPECT_NEAR(da[j], numeric, 1e-6 + 1e-4 * std::abs(numeric))
          << "means_a " << j;
    }
    for (std::size_t j = 0; j < s.means_b.size(); ++j) {
      Scene plus = s, minus = s;
      plus.means_b[j] += kStep;
      minus.means_b[j] -= kStep;
      const double numeric =
          (Evaluate(plus, nullptr, nullptr, huber).loss -
           Evaluate(minus, nullptr, nullptr, huber).loss) /
          (2 * kStep);
      EXPECT_NEAR(db[j], numeric, 1e-6 + 1e-4 * std::abs(numeric))
          << "means_b " << j;
    }
  }
}

TEST(FlowLossTest, MismatchedSizesAreErrors) {
  const Scene s = MakeScene(5, 0, 4);
  std::vector<double> a(s.model.size() * 3, 0.0), b(s.means_b.size(), 0.0);
  EXPECT_THROW(FlowLoss(s.model, 0, s.means_b, CameraAt(0), CameraAt(0.2),
                        std::vector<float>(10), Valid(), kSurface, 1.0, 0.05,
                        2.0, &a, &b),
               Error);
  std::vector<double> short_b(3, 0.0);
  EXPECT_THROW(FlowLoss(s.model, 0, s.means_b, CameraAt(0), CameraAt(0.2),
                        Flow(0, 0), Valid(), kSurface, 1.0, 0.05, 2.0, &a,
                        &short_b),
               Error);
}

// Disparity 7 - 2 / z: an affine of the render's inverse depth.
TEST(DisparityLossTest, InvariantToTheAffineAndGradientChecked) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> depth(2.0f, 6.0f);
  std::vector<float> z(200), disparity(200);
  for (std::size_t p = 0; p < z.size(); ++p) {
    z[p] = depth(rng);
    disparity[p] = 7.0f - 2.0f / z[p];
  }
  z[7] = 0;  // no render there
  disparity[9] = NAN;  // no prior there
  std::vector<float> d(z.size(), 0.0f);
  const DisparityTerm exact = DisparityLoss(disparity, z, 1.0, &d);
  EXPECT_EQ(exact.pixels, 198);
  EXPECT_LT(exact.loss, 1e-6);
  EXPECT_NEAR(exact.scale, -0.5, 1e-5);

  // A render off the prior's shape: a loss, and its gradient (the affine
  // held fixed) against central differences of the loss with that affine.
  for (std::size_t p = 0; p < z.size(); p += 3) z[p] *= 1.2f;
  std::fill(d.begin(), d.end(), 0.0f);
  const DisparityTerm off = DisparityLoss(disparity, z, 1.0, &d);
  EXPECT_GT(off.loss, 1e-3);
  EXPECT_EQ(d[7], 0.0f);
  EXPECT_EQ(d[9], 0.0f);
  std::vector<double> inverse;
  for (std::size_t p = 0; p < z.size(); ++p)
    if (z[p] > 0 && std::isfinite(disparity[p])) inverse.push_back(1.0 / z[p]);
  std::nth_element(inverse.begin(), inverse.begin() + inverse.size() / 2,
                   inverse.end());
  const double median = inverse[inverse.size() / 2];
  for (std::size_t p : {0u, 1u, 3u, 50u}) {
    const auto term = [&](double zp) {
      return std::abs(off.scale * disparity[p] + off.shift - 1.0 / zp) /
             (off.pixels * median);
    };
    const double h = 1e-4;
    const double numeric = (term(z[p] + h) - term(z[p] - h)) / (2 * h);
    EXPECT_NEAR(d[p], numeric, 1e-4 * std::abs(numeric) + 1e-9) << p;
  }
  // With a mask only its pixels count, with an affine of their own.
  std::vector<std::uint8_t> mask(z.size(), 0);
  for (std::size_t p = 0; p < 100; ++p) mask[p] = 255;
  std::fill(d.begin(), d.end(), 0.0f);
  const DisparityTerm masked = DisparityLoss(disparity, z, 1.0, &d, &mask);
  EXPECT_EQ(masked.pixels, 98);  // pixels 7 and 9 have no render / prior
  EXPECT_EQ(d[150], 0.0f);
  EXPECT_NE(d[0], 0.0f);
}

}  // namespace
}  // namespace pano4d
