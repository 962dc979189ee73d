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

  Timer busy;
  volatile double x = 0;
  while (busy.WallSeconds() < 0.1) x = x + std::sqrt(x + 1.0);
  EXPECT_GT(busy.CpuSeconds(), 0.02);
  EXPECT_GE(busy.CpuSeconds(), 0.0);

  busy.Restart();
  EXPECT_LT(busy.WallSeconds(), 0.05);
}

}  // namespace
}  // namespace pano4d
