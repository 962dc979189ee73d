// Label slow: the demo's small preset, for the acceptance bound on the
// unseen fraction (u* metrics need enough unseen pixels to mean something,
// m* metrics enough covisible ones).
#include <gtest/gtest.h>

#include "src/datasets/synth_generate.h"
#include "tests/support/test_files.h"

namespace pano4d::synth {
namespace {

TEST(SynthSmallTest,
     UnseenFractionOfValidationPixelsIsBetweenTenAndSixtyPercent) {
  testing::TempDir dir;
  const SynthSummary summary =
      GenerateSynthScene({"small", 0, false}, dir.path());
  std::cout << "small preset: unseen fraction " << summary.unseen_fraction
            << " of " << summary.val_pixels << " validation pixels\n";
  EXPECT_GT(summary.unseen_fraction, 0.10);
  EXPECT_LT(summary.unseen_fraction, 0.60);
}

}  // namespace
}  // namespace pano4d::synth
