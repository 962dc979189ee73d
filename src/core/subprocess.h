#pragma once

// Child processes: external tools (colmap) and pano4d's own stages run as
// separate processes (bench datasets), each with its output in a log file.

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
  int exit_code = -1;  // -1 when killed by a signal
  int signal = 0;      // the signal that killed it, or 0
  double seconds = 0.0;
  // Peak resident memory of the child or its largest waited-for descendant
  // (wait4's ru_maxrss), in MiB.
  double peak_memory_mib = 0.0;
  bool ok() const { return exit_code == 0; }
  std::string How() const;  // "exit status 3", "killed by signal 9"
};

// Runs argv[0] (a path) with argv[1..], stdin from /dev/null, stdout and
// stderr appended to `log`, whose first line is the command line (so that
// it can be rerun by hand), and waits for it. Throws pano4d::Error naming
// the executable when it cannot start.
ProcessResult RunProcess(const std::vector<std::string>& argv,
                         const std::filesystem::path& log);

// The last `count` non-empty lines of a text file (for error messages).
std::string LastLines(const std::filesystem::path& path, int count);

}  // namespace pano4d
