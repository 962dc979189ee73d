#include "colmap_ext/colmap_runner.h"

#include <algorithm>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/log.h"

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

std::string ColmapRunner::Help(const std::vector<std::string>& args,
                               const std::filesystem::path& log) const {
  std::vector<std::string> argv = {executable_.string()};
  argv.insert(argv.end(), args.begin(), args.end());
  EnsureDirectory(log.parent_path());
  std::filesystem::remove(log);
  // The exit status of a help request differs between versions; what it
  // printed is what counts, and the callers check that.
  RunProcess(argv, log);
  return ReadTextFile(log);
}

const ColmapVersion& ColmapRunner::Version(
    const std::filesystem::path& log_dir) const {
  if (version_) return *version_;
  const std::filesystem::path log = log_dir / "colmap_help.log";
  const std::optional<ColmapVersion> v =
      ParseColmapVersion(Help({"help"}, log));
  if (!v) {
    throw Error("colmap", "help", executable_.string(),
                "printed no \"COLMAP <version>\" line (log: " + log.string() +
                    "); is it COLMAP?");
  }
  if (!CheckColmapVersion(*v)) {
    PANO4D_LOG(kWarning) << "colmap " << v->text
                         << " is newer than the versions pano4d was tested "
                            "with ("
                         << kTestedColmapVersions
                         << "); its options are checked before each run";
  }
  version_ = v;
  return *version_;
}

std::vector<std::string> ColmapRunner::MapArgs(
    const std::string& subcommand, const std::vector<std::string>& args,
    const std::filesystem::path& log_dir) const {
  const ColmapVersion& version = Version(log_dir);
  auto found = options_.find(subcommand);
  if (found == options_.end()) {
    const std::string help =
        Help({subcommand, "-h"}, log_dir / (subcommand + "_help.log"));
    std::set<std::string> options = ParseColmapOptions(help);
    if (options.empty()) {
      throw Error("colmap " + version.text, subcommand, "",
                  "`colmap " + subcommand + " -h` listed no options (log: " +
                      (log_dir / (subcommand + "_help.log")).string() +
                      "); is it a COLMAP command?");
    }
    found = options_.emplace(subcommand, std::move(options)).first;
  }
  std::vector<std::string> mapped;
  for (const std::string& a : args) {
    mapped.push_back(a.rfind("--", 0) == 0
                         ? "--" + MapColmapOption(a.substr(2), subcommand,
                                                  found->second, version)
                         : a);
  }
  return mapped;
}

ColmapRun ColmapRunner::Run(const std::string& subcommand,
                            const std::vector<std::string>& args,
                            const std::filesystem::path& log,
                            const std::string& remedy) const {
  std::vector<std::string> argv = {executable_.string(), subcommand};
  const std::vector<std::string> mapped =
      MapArgs(subcommand, args, log.parent_path());
  argv.insert(argv.end(), mapped.begin(), mapped.end());
  const ProcessResult result = RunProcess(argv, log);
  ColmapRun run{subcommand, log, result.seconds};
  if (result.ok()) return run;
  std::string problem =
      "colmap " + subcommand + " failed: " + ProcessFailure(result, log);
  if (!remedy.empty()) problem += "; likely remedy: " + remedy;
  throw Error("colmap", subcommand, "", problem);
}

}  // namespace pano4d
