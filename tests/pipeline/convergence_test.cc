#include "src/pipeline/convergence.h"

#include <cmath>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

ConvergenceOptions Every100Window200(double min_gain) {
  ConvergenceOptions o;
  o.every = 100;
  o.window = 200;
  o.min_gain = min_gain;
  return o;
}

// Samples start after the gate; the stop compares a sample with the one a
// window before it and says why it stopped.
TEST(ConvergenceTest, StopsWhenTheWindowGainedLessThanTheMinimum) {
  ConvergenceRule rule(Every100Window200(0.1), 200);
  EXPECT_FALSE(rule.Due(100));  // before the gate
  EXPECT_FALSE(rule.Due(200));  // the gate itself: before its change
  EXPECT_FALSE(rule.Due(350));
  EXPECT_TRUE(rule.Due(300));
  EXPECT_FALSE(rule.Add(300, 20.0));
  EXPECT_FALSE(rule.Add(400, 20.5));
  EXPECT_FALSE(rule.Add(500, 20.6));  // 0.6 dB over 300..500
  EXPECT_FALSE(rule.Add(600, 20.7));  // 0.2 dB over 400..600
  const std::optional<std::string> why = rule.Add(700, 20.65);
  ASSERT_TRUE(why);  // 0.05 dB over 500..700
  EXPECT_NE(why->find("gained 0.050 dB over the last 200 iterations"),
            std::string::npos)
      << *why;
  EXPECT_EQ(rule.reason(), *why);
  EXPECT_EQ(rule.samples().size(), 5u);
}

// A signal that got worse stops too (a gain below the minimum); a NaN sample
// is not kept and stops nothing.
TEST(ConvergenceTest, ALossStopsAndANanIsIgnored) {
  ConvergenceRule rule(Every100Window200(0.0), 0);
  EXPECT_FALSE(rule.Add(100, 20.0));
  EXPECT_FALSE(rule.Add(200, std::nan("")));
  EXPECT_FALSE(rule.Add(300, 21.0));  // +1 dB against 100
  EXPECT_EQ(rule.samples().size(), 2u);
  EXPECT_FALSE(rule.Add(400, 21.5));  // 200 has no sample to compare with
  EXPECT_TRUE(rule.Add(500, 20.9));   // -0.1 dB against 300
}

// A resumed run takes back the samples up to its checkpoint and decides as
// the uninterrupted run did.
TEST(ConvergenceTest, RestoreKeepsSamplesUpToTheCheckpointAndRedecides) {
  ConvergenceRule full(Every100Window200(0.1), 0);
  for (auto [it, v] :
       {std::pair<std::int64_t, double>{100, 20.0}, {200, 20.5}, {300, 20.05}})
    full.Add(it, v);
  ASSERT_FALSE(full.reason().empty());  // 0.05 dB over 100..300
  ConvergenceRule resumed(Every100Window200(0.1), 0);
  resumed.Restore(full.samples(), 200);
  EXPECT_EQ(resumed.samples().size(), 2u);
  EXPECT_TRUE(resumed.reason().empty());
  resumed.Restore(full.samples(), 300);
  EXPECT_EQ(resumed.reason(), full.reason());
}

TEST(ConvergenceTest, GateFollowsTheLastStructuralChange) {
  EXPECT_EQ(ConvergenceGate(0, 1000), 1000);
  EXPECT_EQ(ConvergenceGate(4000, 2400), 4000);
  EXPECT_EQ(ConvergenceGate(0, -1), 0);
}

TEST(ConvergenceTest, OptionsAndNamesAreChecked) {
  EXPECT_NO_THROW(ConvergenceOptions{}.Check());
  ConvergenceOptions odd;
  odd.window = 300;
  odd.every = 200;
  EXPECT_THROW(odd.Check(), Error);
  ConvergenceOptions negative;
  negative.min_gain = -1;
  EXPECT_THROW(negative.Check(), Error);
  ConvergenceOptions nan;
  nan.min_gain = std::nan("");
  EXPECT_THROW(nan.Check(), Error);
  for (ConvergeOn c : {ConvergeOn::kOff, ConvergeOn::kAuto,
                       ConvergeOn::kValidation, ConvergeOn::kTraining})
    EXPECT_EQ(ParseConvergeOn(ConvergeOnName(c)), c);
  try {
    ParseConvergeOn("sometimes");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), "--converge-on");
  }
  EXPECT_EQ(ResolveConvergeOn(ConvergeOn::kAuto, true),
            ConvergeOn::kValidation);
  EXPECT_EQ(ResolveConvergeOn(ConvergeOn::kAuto, false), ConvergeOn::kTraining);
  EXPECT_EQ(ResolveConvergeOn(ConvergeOn::kOff, true), ConvergeOn::kOff);
}

}  // namespace
}  // namespace pano4d
