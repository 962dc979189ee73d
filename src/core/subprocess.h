#pragma once

// Child processes: external tools (colmap, a prior command) and pano4d's
// own stages run as separate processes (bench datasets), each with its
// output in a log file.

#include <signal.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace pano4d {

// The first executable called `name` on PATH (as a shell would find it), or
// nullopt.
std::optional<std::filesystem::path> FindOnPath(const std::string& name);

// How a child process ended.
struct ProcessResult {
  int exit_code = -1;       // -1 when killed by a signal
  int signal = 0;           // the signal that killed it, or 0
  bool timed_out = false;   // stopped at ProcessOptions::timeout_seconds
  double time_limit_s = 0;  // that limit, when timed_out
  double seconds = 0.0;
  // Peak resident memory of the child or its largest waited-for descendant
  // (wait4's ru_maxrss), in MiB.
  double peak_memory_mib = 0.0;
  bool ok() const { return exit_code == 0; }
  // "exit status 3", "exit status 127 (command not found?)", "killed by
  // signal 9", "stopped at its time limit of 0.5 s"
  std::string How() const;
};

// A child that outlives its time limit gets SIGTERM, and SIGKILL this many
// seconds later if it is still there: a moment to let a model server
// close its files, short enough that Ctrl-C feels immediate.
inline constexpr double kStopGraceSeconds = 0.5;

struct ProcessOptions {
  // Seconds after which the child's process group is stopped (SIGTERM,
  // then SIGKILL after kStopGraceSeconds); 0: no limit. Needs own_group.
  double timeout_seconds = 0.0;
  // The child leads its own process group, so that a stop reaches all it
  // started (a shell's pipeline). While it runs, SIGINT, SIGTERM, SIGHUP
  // and SIGQUIT to pano4d (unless pano4d ignores them) stop the group
  // first and then end pano4d as the signal would have: the terminal's
  // Ctrl-C no longer reaches the group by itself. A pano4d killed with
  // SIGKILL cannot pass anything on: the group then runs on by itself.
  bool own_group = false;
  // Pass on to the child (not its group) what pano4d receives while it
  // runs, once each: the stop signal (stop_signal.h: it checkpoints and
  // exits 75) and, inside a SignalsForwarded scope, SIGINT, SIGTERM and
  // SIGHUP; then wait for it. For pano4d's own children (`sweep run`,
  // `sweep local`), which save their state when told. Not with own_group.
  bool forward_signals = false;
};

// While alive, SIGINT, SIGTERM and SIGHUP (unless ignored) are remembered
// instead of ending pano4d, for RunProcess calls with forward_signals to
// pass on; at the end, one that arrived ends pano4d as it would have
// (after the children it reached have ended). One scope at a time, set up
// before the threads that run children start.
class SignalsForwarded {
 public:
  SignalsForwarded();
  ~SignalsForwarded();
  SignalsForwarded(const SignalsForwarded&) = delete;
  SignalsForwarded& operator=(const SignalsForwarded&) = delete;
  // The signal that arrived, or 0.
  static int Received();

 private:
  struct sigaction old_[3]{};  // SIGINT, SIGTERM, SIGHUP's actions before
};

// Runs argv[0] (a path) with argv[1..], stdin from /dev/null, stdout and
// stderr appended to `log`, whose first line is the command line (so that
// it can be rerun by hand), and waits for it. Throws pano4d::Error naming
// the executable when it cannot start.
ProcessResult RunProcess(const std::vector<std::string>& argv,
                         const std::filesystem::path& log,
                         const ProcessOptions& options = {});

// The last `count` non-empty lines of a text file.
std::string LastLines(const std::filesystem::path& path, int count);

// One line saying how a child failed, for an error message: its How(), the
// line of its log that says why, quoted, and the log, e.g.
//   exit status 1: "pano4d: error: ..." (log: WS/logs/run.log)
// The line is the last of the log's last 40 that holds "error" or
// "failed" (any case), else its last line (never the command line
// RunProcess heads the log with), shortened to kQuotedLogChars.
inline constexpr std::size_t kQuotedLogChars = 300;
std::string ProcessFailure(const ProcessResult& result,
                           const std::filesystem::path& log);

}  // namespace pano4d
