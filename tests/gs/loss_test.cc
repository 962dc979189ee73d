#include "src/gs/loss.h"

#include <cmath>
#include <cstring>
#include <random>
#include <utility>

#include <omp.h>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

std::vector<float> RandomImage(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.1f, 0.9f);
  std::vector<float> v(static_cast<std::size_t>(w) * h * 3);
  for (float& x : v) x = u(rng);
  return v;
}

TEST(PhotometricLossTest, IdenticalImagesHaveZeroLoss) {
  const std::vector<float> a = RandomImage(20, 16, 1);
  std::vector<float> grad;
  const PhotometricLoss l = ComputePhotometricLoss(a, a, 20, 16, 0.2, &grad);
  EXPECT_NEAR(l.l1, 0.0, 1e-12);
  EXPECT_NEAR(l.ssim, 1.0, 1e-9);
  EXPECT_NEAR(l.total, 0.0, 1e-9);
}

TEST(PhotometricLossTest, GradientMatchesCentralDifferences) {
  const int w = 23, h = 17;
  const std::vector<float> target = RandomImage(w, h, 2);
  std::vector<float> rendered = RandomImage(w, h, 3);
  std::vector<float> grad;
  ComputePhotometricLoss(rendered, target, w, h, 0.2, &grad);
  std::mt19937 rng(4);
  int checked = 0, good = 0;
  for (int k = 0; k < 200; ++k) {
    const std::size_t i = rng() % rendered.size();
    if (std::abs(rendered[i] - target[i]) < 0.01f) continue;  // |.| kink
    const float saved = rendered[i];
    const float step = 1e-3f;
    rendered[i] = saved + step;
    const double plus = ComputePhotometricLoss(rendered, target, w, h).total;
    rendered[i] = saved - step;
    const double minus = ComputePhotometricLoss(rendered, target, w, h).total;
    rendered[i] = saved;
    const double numeric = (plus - minus) / (2.0 * step);
    ++checked;
    if (std::abs(numeric - grad[i]) <= 1e-3 * std::abs(numeric) + 1e-9)
      ++good;
    else
      ADD_FAILURE() << "pixel value " << i << ": analytic " << grad[i]
                    << ", numeric " << numeric;
  }
  EXPECT_GT(checked, 150);
  EXPECT_EQ(good, checked);
}

// Each thread streams a band of rows and recomputes the rows beyond its
// edges that it reads; sums are added in row order: the loss and its
// gradient are the same bytes whatever the thread count, also with bands
// thinner than the window and with more threads than rows.
TEST(PhotometricLossTest, SameBytesWhateverTheThreads) {
  const int threads = omp_get_max_threads();
  for (const auto& [w, h] : {std::pair{61, 37}, std::pair{9, 3}}) {
    const std::vector<float> a = RandomImage(w, h, 8), b = RandomImage(w, h, 9);
    const auto run = [&](int t, std::vector<float>* grad) {
      omp_set_num_threads(t);
      PhotometricLossBuffers buffers;
      return ComputePhotometricLoss(a, b, w, h, 0.2, grad, &buffers);
    };
    std::vector<float> g1;
    const PhotometricLoss one = run(1, &g1);
    for (int t : {2, 3, 5}) {
      std::vector<float> g;
      const PhotometricLoss many = run(t, &g);
      EXPECT_EQ(one.total, many.total) << w << "x" << h << ", " << t;
      EXPECT_EQ(one.ssim, many.ssim) << w << "x" << h << ", " << t;
      EXPECT_EQ(one.mse, many.mse) << w << "x" << h << ", " << t;
      ASSERT_EQ(g1.size(), g.size());
      EXPECT_EQ(std::memcmp(g1.data(), g.data(), g1.size() * sizeof(float)), 0)
          << w << "x" << h << ", " << t << " threads";
    }
    omp_set_num_threads(threads);
    // Reused buffers give the same result again, also after another size.
    PhotometricLossBuffers buffers;
    std::vector<float> g3;
    const std::vector<float> small = RandomImage(5, 4, 10);
    ComputePhotometricLoss(small, small, 5, 4, 0.2, &g3, &buffers);
    ComputePhotometricLoss(b, a, w, h, 0.2, &g3, &buffers);
    EXPECT_EQ(ComputePhotometricLoss(a, b, w, h, 0.2, &g3, &buffers).total,
              one.total);
    EXPECT_EQ(g3, g1);
  }
}

TEST(PhotometricLossTest, SsimOnlyAndL1OnlyWeights) {
  const std::vector<float> a = RandomImage(12, 12, 5),
                           b = RandomImage(12, 12, 6);
  const PhotometricLoss l1 = ComputePhotometricLoss(a, b, 12, 12, 0.0);
  EXPECT_DOUBLE_EQ(l1.total, l1.l1);
  const PhotometricLoss ssim = ComputePhotometricLoss(a, b, 12, 12, 1.0);
  EXPECT_DOUBLE_EQ(ssim.total, 1 - ssim.ssim);
  EXPECT_LT(ssim.ssim, 0.5);  // unrelated noise images
}

TEST(PhotometricLossTest, BadInputsAreErrors) {
  std::vector<float> a = RandomImage(4, 4, 7);
  EXPECT_THROW(ComputePhotometricLoss(a, a, 5, 4), Error);
  std::vector<float> b = a;
  b[3] = std::nanf("");
  EXPECT_THROW(ComputePhotometricLoss(a, b, 4, 4), Error);
  EXPECT_THROW(ComputePhotometricLoss(a, a, 4, 4, 1.5), Error);
}

}  // namespace
}  // namespace pano4d
