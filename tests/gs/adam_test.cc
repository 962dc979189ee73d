#include "src/gs/adam.h"

#include <cmath>

#include <gtest/gtest.h>

#include "src/core/check.h"
#include "src/core/error.h"

namespace pano4d {
namespace {

TEST(AdamTest, FirstStepMovesEachParameterByTheLearningRate) {
  // At step 1, m_hat / sqrt(v_hat) = g / |g|: every parameter moves by lr
  // against its gradient's sign, whatever the gradient's size.
  std::vector<float> x = {1.0f, 2.0f, -3.0f};
  Adam adam;
  adam.AddGroup("x", &x, 1, 0.1);
  const std::vector<float> g = {1e-6f, -50.0f, 0.3f};
  adam.Step({&g});
  EXPECT_NEAR(x[0], 0.9f, 1e-6);
  EXPECT_NEAR(x[1], 2.1f, 1e-6);
  EXPECT_NEAR(x[2], -3.1f, 1e-6);
}

TEST(AdamTest, MatchesTheReferenceFormulaOverSeveralSteps) {
  std::vector<float> x = {0.5f, -0.25f};
  Adam adam({.beta1 = 0.9, .beta2 = 0.999, .epsilon = 1e-8});
  adam.AddGroup("x", &x, 2, 0.01);
  double ref[2] = {0.5, -0.25}, m[2] = {0, 0}, v[2] = {0, 0};
  for (int t = 1; t <= 5; ++t) {
    const std::vector<float> g = {static_cast<float>(0.3 * t),
                                  static_cast<float>(-0.1 / t)};
    adam.Step({&g});
    for (int i = 0; i < 2; ++i) {
      m[i] = 0.9 * m[i] + 0.1 * g[i];
      v[i] = 0.999 * v[i] + 0.001 * g[i] * g[i];
      const double m_hat = m[i] / (1 - std::pow(0.9, t));
      const double v_hat = v[i] / (1 - std::pow(0.999, t));
      ref[i] -= 0.01 * m_hat / (std::sqrt(v_hat) + 1e-8);
    }
  }
  EXPECT_NEAR(x[0], ref[0], 1e-6);
  EXPECT_NEAR(x[1], ref[1], 1e-6);
}

TEST(AdamTest, MinimisesAQuadratic) {
  std::vector<float> x = {5.0f, -4.0f, 0.0f};
  const std::vector<float> target = {1.0f, 2.0f, -3.0f};
  Adam adam;
  adam.AddGroup("x", &x, 3, 0.05);
  std::vector<float> g(3);
  for (int step = 0; step < 2000; ++step) {
    for (int i = 0; i < 3; ++i) g[i] = 2 * (x[i] - target[i]);
    adam.Step({&g});
  }
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(x[i], target[i], 1e-2);
}

TEST(AdamTest, RowsWithNonFiniteGradientsAreSkippedAndCounted) {
  std::vector<float> x = {1, 1, 1, 1, 1, 1};  // 3 rows of 2
  Adam adam;
  adam.AddGroup("x", &x, 2, 0.1);
  const std::vector<float> g = {1, 1, std::nanf(""), 1, 1, INFINITY};
  const AdamStepStats stats = adam.Step({&g});
  EXPECT_EQ(stats.skipped_rows, 2);
  EXPECT_FLOAT_EQ(x[0], 0.9f);
  EXPECT_FLOAT_EQ(x[2], 1.0f);  // row 1 untouched
  EXPECT_FLOAT_EQ(x[3], 1.0f);
  EXPECT_EQ(adam.first_moment(0)[2], 0.0f);  // and its moments too
  for (const float v : x) EXPECT_TRUE(std::isfinite(v));
}

TEST(AdamTest, MomentsFollowAppendedAndRemovedRows) {
  std::vector<float> means = {0, 0, 0, 1, 1, 1};  // 2 rows of 3
  std::vector<float> opacity = {0, 1};
  Adam adam;
  adam.AddGroup("means", &means, 3, 0.1);
  adam.AddGroup("opacity", &opacity, 1, 0.1);
  const std::vector<float> gm = {1, 1, 1, 2, 2, 2}, go = {3, 4};
  adam.Step({&gm, &go});
  // Densify: one new row, with fresh moments.
  means.insert(means.end(), {5, 5, 5});
  opacity.push_back(0.5f);
  adam.AppendRows(1);
  EXPECT_EQ(adam.rows(), 3);
  EXPECT_EQ(adam.first_moment(0)[6], 0.0f);
  // Prune row 0: row 1's moments move to the front.
  const float m_row1 = adam.first_moment(1)[1];
  means.erase(means.begin(), means.begin() + 3);
  opacity.erase(opacity.begin());
  adam.KeepRows({0, 1, 1});
  EXPECT_EQ(adam.rows(), 2);
  EXPECT_EQ(adam.first_moment(1)[0], m_row1);
  // A group resized behind the optimiser's back is a bug in pano4d, caught
  // as such, not a crash.
  means.push_back(1);
  EXPECT_THROW(adam.Step({&gm, &go}), InternalError);
}

TEST(AdamTest, GroupsMustAgreeOnRows) {
  std::vector<float> a(6), b(4);
  Adam adam;
  adam.AddGroup("a", &a, 3, 0.1);
  EXPECT_THROW(adam.AddGroup("b", &b, 1, 0.1), InternalError);
  std::vector<float> c(5);
  EXPECT_THROW(adam.AddGroup("c", &c, 3, 0.1), InternalError);
  EXPECT_THROW(Adam({.epsilon = 0}), Error);
}

TEST(AdamTest, ExponentialScheduleIsLogLinear) {
  EXPECT_DOUBLE_EQ(ExponentialLearningRate(1e-2, 1e-4, 0, 100), 1e-2);
  EXPECT_NEAR(ExponentialLearningRate(1e-2, 1e-4, 50, 100), 1e-3, 1e-12);
  EXPECT_DOUBLE_EQ(ExponentialLearningRate(1e-2, 1e-4, 100, 100), 1e-4);
  EXPECT_DOUBLE_EQ(ExponentialLearningRate(1e-2, 1e-4, 500, 100), 1e-4);
}

}  // namespace
}  // namespace pano4d
