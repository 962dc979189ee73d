#include "src/core/stop_signal.h"

#include <csignal>

namespace pano4d {
namespace {

volatile std::sig_atomic_t stop_requested = 0;

extern "C" void OnStopSignal(int) { stop_requested = 1; }

}  // namespace

int StopSignal() { return SIGUSR1; }

void InstallStopSignalHandler() {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGUSR1, &action, nullptr);
}

bool StopRequested() { return stop_requested != 0; }
void ClearStopRequest() { stop_requested = 0; }
void RequestStop() { stop_requested = 1; }

}  // namespace pano4d
