#include "src/gs/appearance.h"

#include <random>

#include <gtest/gtest.h>

namespace pano4d {
namespace {

// A scalar loss of the transformed image: sum of w . out, with fixed
// random weights w, so that dL/dout = w.
double Loss(const std::vector<float>& transform, const std::vector<float>& rgb,
            const std::vector<float>& w) {
  std::vector<float> out;
  ApplyAppearance(transform.data(), rgb, &out);
  double sum = 0;
  for (std::size_t i = 0; i < out.size(); ++i) sum += double(w[i]) * out[i];
  return sum;
}

TEST(AppearanceTest, IdentityLeavesTheImageAsItIs) {
  const std::vector<float> rgb = {0.1f, 0.5f, 0.9f, 0.3f, 0.2f, 0.0f};
  std::vector<float> out;
  ApplyAppearance(IdentityAppearance().data(), rgb, &out);
  EXPECT_EQ(out, rgb);
}

TEST(AppearanceTest, GradientsMatchFiniteDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f), g(-1.0f, 1.0f);
  std::vector<float> rgb(5 * 4 * 3), w(rgb.size());
  for (float& v : rgb) v = u(rng);
  for (float& v : w) v = g(rng);
  std::vector<float> transform = IdentityAppearance();
  for (float& v : transform) v += 0.2f * g(rng);

  std::vector<float> d_rgb, d_transform(kAppearanceWidth, 0.0f);
  ApplyAppearanceBackward(transform.data(), rgb, w, &d_rgb, d_transform.data());
  constexpr float kStep = 1e-2f;  // the loss is linear in each parameter
  for (int k = 0; k < kAppearanceWidth; ++k) {
    std::vector<float> plus = transform, minus = transform;
    plus[k] += kStep;
    minus[k] -= kStep;
    const double numeric =
        (Loss(plus, rgb, w) - Loss(minus, rgb, w)) / (2.0 * kStep);
    EXPECT_NEAR(d_transform[k], numeric, 1e-3 * (1 + std::abs(numeric)))
        << "parameter " << k;
  }
  for (std::size_t i = 0; i < rgb.size(); i += 7) {
    std::vector<float> plus = rgb, minus = rgb;
    plus[i] += kStep;
    minus[i] -= kStep;
    const double numeric =
        (Loss(transform, plus, w) - Loss(transform, minus, w)) / (2.0 * kStep);
    EXPECT_NEAR(d_rgb[i], numeric, 1e-3) << "value " << i;
  }
}

TEST(AppearanceTest, RegulariserIsZeroAtTheIdentityAndPullsBackToIt) {
  std::vector<float> grad(kAppearanceWidth, 0.0f);
  EXPECT_EQ(
      AppearanceRegulariser(IdentityAppearance().data(), 1.0, grad.data()),
      0.0);
  for (float v : grad) EXPECT_EQ(v, 0.0f);
  std::vector<float> off = IdentityAppearance();
  off[0] = 1.5f;    // gain of red
  off[11] = -0.2f;  // bias of blue
  EXPECT_NEAR(AppearanceRegulariser(off.data(), 2.0, grad.data()),
              2.0 * (0.25 + 0.04), 1e-6);
  EXPECT_GT(grad[0], 0.0f);   // descent lowers the gain
  EXPECT_LT(grad[11], 0.0f);  // and raises the bias
}

}  // namespace
}  // namespace pano4d
