#pragma once

#include <chrono>

namespace pano4d {

// CPU time used so far by all threads of this process, in seconds.
double ProcessCpuSeconds();

// Wall and CPU time since construction or the last Restart(). With several
// threads busy, CpuSeconds() exceeds WallSeconds(); their ratio is the mean
// parallelism, which every stage reports beside its wall time.
class Timer {
 public:
  Timer() { Restart(); }
  void Restart();
  double WallSeconds() const;
  double CpuSeconds() const;

 private:
  std::chrono::steady_clock::time_point wall_start_;
  double cpu_start_ = 0.0;
};

}  // namespace pano4d
