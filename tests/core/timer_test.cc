#include "src/core/timer.h"

#include <chrono>
#include <cmath>
#include <thread>

#include <gtest/gtest.h>

namespace pano4d {
namespace {

// Behaviour, not speed: busy work shows up as CPU time, sleeping does not.
TEST(TimerTest, CpuTimeCountsWorkNotSleep) {
  Timer sleeping;
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_GE(sleeping.WallSeconds(), 0.045);
  EXPECT_LT(sleeping.CpuSeconds(), 0.03);

  // Work until the CPU clock has advanced 20 ms: on a loaded machine that
  // takes longer than 20 ms of wall time, never shorter; the wall limit
  // only stops a clock that does not count work.
  Timer busy;
  volatile double x = 0;
  while (busy.CpuSeconds() < 0.02 && busy.WallSeconds() < 30.0)
    x = x + std::sqrt(x + 1.0);
  EXPECT_GE(busy.CpuSeconds(), 0.02);
  EXPECT_GE(busy.WallSeconds(), 0.9 * busy.CpuSeconds());  // one thread

  busy.Restart();
  EXPECT_LT(busy.WallSeconds(), 0.05);
}

}  // namespace
}  // namespace pano4d
