#include <unistd.h>

#include <cstdlib>

#include "src/cli/app.h"
#include "src/core/stop_signal.h"

namespace {

// OpenMP's idle workers spin at the end of every parallel region (libgomp:
// some 300,000 iterations) and burn the CPU that another process on the
// machine needs: with one CPU-bound neighbour on 2 cores, pano4d's fit ran
// slower on two threads than on one, and with passive waits as fast
// (docs/experiments/2026-12-02-threads-on-a-busy-machine.md). libgomp reads
// OMP_WAIT_POLICY once, when it loads, so pano4d sets it and executes
// itself again; a user's own OMP_WAIT_POLICY or GOMP_SPINCOUNT is kept.
void ExecuteWithPassiveWaits(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") || std::getenv("GOMP_SPINCOUNT")) return;
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  execv("/proc/self/exe", argv);
  // No /proc (or no permission): go on with the spinning default.
  unsetenv("OMP_WAIT_POLICY");
}

}  // namespace

int main(int argc, char** argv) {
  ExecuteWithPassiveWaits(argv);
  pano4d::InstallStopSignalHandler();
  return pano4d::cli::Main(argc, argv);
}
