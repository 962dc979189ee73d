#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "src/core/subprocess.h"

namespace pano4d {

// What one finished colmap subcommand took.
struct ColmapRun {
  std::string subcommand;
  std::filesystem::path log;
  double seconds = 0.0;
};

// Runs the colmap command-line tool as a subprocess, one subcommand at a
// time, with its stdout and stderr in a log file. colmap is a run-time tool:
// pano4d never links it.
class ColmapRunner {
 public:
  // `executable` empty: colmap from PATH. Throws pano4d::Error with the
  // install command when it is not there.
  explicit ColmapRunner(std::filesystem::path executable = {});

  // Runs `colmap subcommand args...` with output to `log` (overwritten). On
  // a non-zero exit or a signal, throws pano4d::Error naming the
  // subcommand, the exit status, the log file, the log's last lines and
  // `remedy` (what usually fixes it), on one line, so that the user need
  // not open the log to know what to do.
  ColmapRun Run(const std::string& subcommand,
                const std::vector<std::string>& args,
                const std::filesystem::path& log,
                const std::string& remedy = {}) const;

  const std::filesystem::path& executable() const { return executable_; }

 private:
  std::filesystem::path executable_;
};

}  // namespace pano4d
