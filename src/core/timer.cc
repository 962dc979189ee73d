#include "src/core/timer.h"

#include <ctime>

namespace pano4d {

double ProcessCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) +
         1e-9 * static_cast<double>(ts.tv_nsec);
}

void Timer::Restart() {
  wall_start_ = std::chrono::steady_clock::now();
  cpu_start_ = ProcessCpuSeconds();
}

double Timer::WallSeconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                       wall_start_)
      .count();
}

double Timer::CpuSeconds() const { return ProcessCpuSeconds() - cpu_start_; }

}  // namespace pano4d
