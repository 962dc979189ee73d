#include "src/gs/strategy.h"

#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "src/core/check.h"

#include "src/core/error.h"

namespace pano4d {
namespace {

// Two static Gaussians: row 0 small (clone when its gradient is large), row
// 1 wide (split), both seen with a radius of 5 pixels in a 64x48 view.
struct Fixture {
  Fixture() {
    scene.statics.Resize(2);
    scene.dynamics.sh_degree = scene.statics.sh_degree;
    for (int i = 0; i < 2; ++i) {
      const float scale = i == 0 ? 0.001f : 0.5f;
      for (int k = 0; k < 3; ++k) {
        scene.statics.means[3 * i + k] = 0.1f * i + k;
        scene.statics.log_scales[3 * i + k] = std::log(scale);
      }
      scene.statics.quats[4 * i] = 1;
      scene.statics.opacities[i] = 2.0f;  // opacity 0.88
    }
    GaussianModel& m = scene.statics;
    statics.AddGroup("means", &m.means, 3, 0.1);
    statics.AddGroup("log_scales", &m.log_scales, 3, 0.1);
    statics.AddGroup("quats", &m.quats, 4, 0.1);
    statics.AddGroup("opacities", &m.opacities, 1, 0.1);
    statics.AddGroup("sh", &m.sh, m.sh_coefficients() * 3, 0.1);
    options.densify_from = 10;
    options.densify_until = 100;
    options.densify_every = 10;
    options.opacity_reset_every = 50;
    options.densify_gradient = 1e-3;
    options.percent_dense = 0.01;  // x extent 1: 0.01 separates the rows
  }
  OptimisedScene Optimised() { return {&scene, &statics, &dynamics}; }
  // A forward state and gradients in which every Gaussian is seen with
  // pixel-mean gradient (g, 0).
  void See(DefaultStrategy* strategy, float g) {
    RasterState state;
    state.width = 64;
    state.height = 48;
    state.projected.Resize(scene.size());
    std::fill(state.projected.radius.begin(), state.projected.radius.end(), 5);
    GaussianGradients grads;
    grads.means2d.assign(2 * scene.size(), 0.0f);
    for (std::size_t i = 0; i < scene.size(); ++i) grads.means2d[2 * i] = g;
    strategy->StepPostBackward(state, grads);
  }

  GaussianScene scene;
  Adam statics, dynamics;
  StrategyOptions options;
};

TEST(DefaultStrategyTest, ClonesSmallAndSplitsLargeGaussiansOnSchedule) {
  Fixture f;
  DefaultStrategy strategy(f.options, /*extent=*/1.0, f.scene.size());
  std::mt19937_64 rng(3);
  f.See(&strategy, 1.0f);  // NDC gradient 32, far above the threshold
  EXPECT_EQ(strategy.statistics().count[0], 1);
  EXPECT_FLOAT_EQ(strategy.statistics().gradient[0], 32.0f);
  strategy.StepPostOptimise(9, f.Optimised(), &rng);  // off schedule
  EXPECT_EQ(f.scene.statics.size(), 2u);
  strategy.StepPostOptimise(10, f.Optimised(), &rng);
  // Row 0 and its clone, then row 1's two samples (the original removed).
  ASSERT_EQ(f.scene.statics.size(), 4u);
  EXPECT_EQ(f.statics.rows(), 4);
  EXPECT_EQ(strategy.densified_total(), 3);
  EXPECT_EQ(strategy.pruned_total(), 0);
  EXPECT_EQ(f.scene.statics.means[3], f.scene.statics.means[0]);  // clone
  for (std::size_t row : {2u, 3u}) {
    EXPECT_NEAR(f.scene.statics.log_scales[3 * row],
                std::log(0.5f) - std::log(1.6f), 1e-6);
  }
  EXPECT_NE(f.scene.statics.means[6], f.scene.statics.means[9]);  // sampled
  // Statistics start afresh, one row per Gaussian.
  EXPECT_EQ(strategy.statistics().count, std::vector<std::int32_t>(4, 0));
}

TEST(DefaultStrategyTest, SmallGradientsChangeNothing) {
  Fixture f;
  DefaultStrategy strategy(f.options, 1.0, f.scene.size());
  std::mt19937_64 rng(3);
  f.See(&strategy, 1e-6f);
  strategy.StepPostOptimise(10, f.Optimised(), &rng);
  EXPECT_EQ(f.scene.statics.size(), 2u);
  EXPECT_EQ(strategy.densified_total(), 0);
}

TEST(DefaultStrategyTest, OpacityResetCapsOpacitiesAndTheirMoments) {
  Fixture f;
  DefaultStrategy strategy(f.options, 1.0, f.scene.size());
  f.statics.Step({&f.scene.statics.means, &f.scene.statics.log_scales,
                  &f.scene.statics.quats, &f.scene.statics.opacities,
                  &f.scene.statics.sh});
  strategy.StepPreForward(49, f.Optimised());
  EXPECT_FALSE(strategy.statistics().reset_done);
  EXPECT_FLOAT_EQ(f.scene.statics.opacities[0], 2.0f - 0.1f);
  strategy.StepPreForward(50, f.Optimised());
  EXPECT_TRUE(strategy.statistics().reset_done);
  EXPECT_NEAR(1 / (1 + std::exp(-f.scene.statics.opacities[0])), 0.01, 1e-6);
  EXPECT_EQ(f.statics.first_moment(3), std::vector<float>(2, 0.0f));
  EXPECT_NE(f.statics.first_moment(0), std::vector<float>(6, 0.0f));
}

TEST(DefaultStrategyTest, LargeGaussiansArePrunedOnlyAfterAReset) {
  Fixture f;
  f.options.densify_gradient = 1e9;  // no growth: pruning alone
  DefaultStrategy strategy(f.options, /*extent=*/1.0, f.scene.size());
  std::mt19937_64 rng(3);
  strategy.StepPostOptimise(10, f.Optimised(), &rng);
  EXPECT_EQ(f.scene.statics.size(), 2u);  // row 1 is 0.5 > 0.1 extent
  strategy.StepPreForward(50, f.Optimised());
  strategy.StepPostOptimise(60, f.Optimised(), &rng);
  ASSERT_EQ(f.scene.statics.size(), 1u);
  EXPECT_EQ(strategy.pruned_total(), 1);
  EXPECT_EQ(f.statics.rows(), 1);
}

TEST(DefaultStrategyTest, AddedAndRemovedRowsKeepStatisticsInStep) {
  Fixture f;
  DefaultStrategy strategy(f.options, 1.0, f.scene.size());
  f.See(&strategy, 1.0f);
  GaussianModel extra;
  extra.Resize(3);
  EXPECT_EQ(strategy.AddStatic(f.Optimised(), extra), 3);
  EXPECT_EQ(f.scene.statics.size(), 5u);
  EXPECT_EQ(f.statics.rows(), 5);
  EXPECT_EQ(strategy.statistics().count,
            (std::vector<std::int32_t>{1, 1, 0, 0, 0}));
  EXPECT_EQ(strategy.RemoveStatic(f.Optimised(), {1, 0, 1, 1, 0}), 2);
  EXPECT_EQ(strategy.statistics().count, (std::vector<std::int32_t>{1, 0, 0}));
  EXPECT_EQ(f.statics.rows(), 3);
  EXPECT_EQ(strategy.pruned_total(), 2);
  EXPECT_THROW(strategy.RemoveStatic(f.Optimised(), {1}), InternalError);
  extra.sh_degree = 1;
  extra.Resize(3);
  EXPECT_THROW(strategy.AddStatic(f.Optimised(), extra), InternalError);
}

// Statistics are per Gaussian of the scene: a forward state of another
// model (e.g. the refinement view's of an older scene) is a bug in pano4d,
// said with both sizes.
TEST(DefaultStrategyTest, AStateOfAnotherSizeIsRefusedNamingBothSizes) {
  Fixture f;
  DefaultStrategy strategy(f.options, 1.0, 7);
  try {
    f.See(&strategy, 1.0f);
    FAIL() << "a state of 2 Gaussians was taken for statistics of 7";
  } catch (const InternalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("7 Gaussians"), std::string::npos) << what;
    EXPECT_NE(what.find("holds 2"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace pano4d
