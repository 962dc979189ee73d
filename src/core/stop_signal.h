#pragma once

// A request to stop at the next safe point, by signal: SIGUSR1, which a
// cluster's scheduler sends before a job's time limit (`sbatch
// --signal=B:USR1@T`, scripts/sweep's batch script). `fit` checkpoints and
// stops at its next iteration, `run` then stops naming the checkpoint, so
// that the same command later resumes; every other command goes on (the
// signal no longer ends the process, as it would by default).

namespace pano4d {

// The signal pano4d takes as "checkpoint and stop".
int StopSignal();

// Installs the handler (main() does, once).
void InstallStopSignalHandler();

// Whether the signal arrived since the handler was installed (or the last
// ClearStopRequest).
bool StopRequested();
void ClearStopRequest();
// The same request made in-process, as the signal makes it: the Python
// module's answer to Ctrl-C while a command runs.
void RequestStop();

// The exit status of a command that stopped on request with its state
// saved (sysexits' EX_TEMPFAIL, "try again"): the batch script of `pano4d
// sweep sbatch` requeues a task that ends with it.
inline constexpr int kStoppedExitStatus = 75;

}  // namespace pano4d
