#include "colmap_ext/colmap_runner.h"

#include <algorithm>

#include "src/core/error.h"

namespace pano4d {

ColmapRunner::ColmapRunner(std::filesystem::path executable)
    : executable_(std::move(executable)) {
  if (executable_.empty()) {
    const auto found = FindOnPath("colmap");
    if (!found) {
      throw Error::In("colmap",
                      "not found on PATH; install it with `sudo apt-get "
                      "install colmap` (Debian/Ubuntu) or see "
                      "https://colmap.github.io/install.html");
    }
    executable_ = *found;
  }
}

ColmapRun ColmapRunner::Run(const std::string& subcommand,
                            const std::vector<std::string>& args,
                            const std::filesystem::path& log,
                            const std::string& remedy) const {
  std::vector<std::string> argv = {executable_.string(), subcommand};
  argv.insert(argv.end(), args.begin(), args.end());
  const ProcessResult result = RunProcess(argv, log);
  ColmapRun run{subcommand, log, result.seconds};
  if (result.ok()) return run;
  const std::string how = result.How();
  std::string problem =
      "colmap " + subcommand + " failed (" + how + "); log: " + log.string();
  if (!remedy.empty()) problem += "; likely remedy: " + remedy;
  // One line, as every pano4d error: the log's last lines joined.
  std::string tail = LastLines(log, 2);
  std::replace(tail.begin(), tail.end(), '\n', '|');
  if (!tail.empty()) problem += "; the log ends: " + tail;
  throw Error("colmap", subcommand, "", problem);
}

}  // namespace pano4d
