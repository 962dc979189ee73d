#pragma once

// Child processes: external tools (colmap, a prior command) and pano4d's
// own stages run as separate processes (bench datasets), each with its
// output in a log file.

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
  int exit_code = -1;      // -1 when killed by a signal
  int signal = 0;          // the signal that killed it, or 0
  bool timed_out = false;  // stopped at ProcessOptions::timeout_seconds
  double seconds = 0.0;
  // Peak resident memory of the child or its largest waited-for descendant
  // (wait4's ru_maxrss), in MiB.
  double peak_memory_mib = 0.0;
  bool ok() const { return exit_code == 0; }
  // "exit status 3", "killed by signal 9", "stopped at its time limit"
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
};

// Runs argv[0] (a path) with argv[1..], stdin from /dev/null, stdout and
// stderr appended to `log`, whose first line is the command line (so that
// it can be rerun by hand), and waits for it. Throws pano4d::Error naming
// the executable when it cannot start.
ProcessResult RunProcess(const std::vector<std::string>& argv,
                         const std::filesystem::path& log,
                         const ProcessOptions& options = {});

// The last `count` non-empty lines of a text file (for error messages).
std::string LastLines(const std::filesystem::path& path, int count);

}  // namespace pano4d
