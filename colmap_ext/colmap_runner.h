#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "colmap_ext/colmap_options.h"
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
// pano4d never links it. Callers pass options by their COLMAP 3.8 names;
// the runner maps them onto the installed version's (colmap_options.h),
// reading `colmap help` and `colmap <subcommand> -h` once each.
class ColmapRunner {
 public:
  // `executable` empty: colmap from PATH. Throws pano4d::Error with the
  // install command when it is not there.
  explicit ColmapRunner(std::filesystem::path executable = {});

  // Runs `colmap subcommand args...` with output to `log` (overwritten). On
  // a non-zero exit or a signal, throws pano4d::Error naming the
  // subcommand, the exit status, the log file, the log's last lines and
  // `remedy` (what usually fixes it), on one line, so that the user need
  // not open the log to know what to do. Before it runs, every "--name"
  // in `args` is mapped as MapArgs does (help outputs logged beside `log`).
  ColmapRun Run(const std::string& subcommand,
                const std::vector<std::string>& args,
                const std::filesystem::path& log,
                const std::string& remedy = {}) const;

  // The installed version, from `colmap help` (logged in
  // log_dir/colmap_help.log). Throws pano4d::Error for a version older
  // than pano4d supports or output without one; warns once for a version
  // newer than the newest tested.
  const ColmapVersion& Version(const std::filesystem::path& log_dir) const;
  // `args` with each "--name" replaced by the name this COLMAP's
  // `subcommand` accepts (MapColmapOption; its -h output logged in
  // log_dir/<subcommand>_help.log). Throws pano4d::Error naming the
  // version, subcommand and option that it lacks.
  std::vector<std::string> MapArgs(const std::string& subcommand,
                                   const std::vector<std::string>& args,
                                   const std::filesystem::path& log_dir) const;

  const std::filesystem::path& executable() const { return executable_; }

 private:
  // What `colmap help`-style output says, with its log.
  std::string Help(const std::vector<std::string>& args,
                   const std::filesystem::path& log) const;

  std::filesystem::path executable_;
  mutable std::optional<ColmapVersion> version_;
  mutable std::map<std::string, std::set<std::string>> options_;
};

}  // namespace pano4d
