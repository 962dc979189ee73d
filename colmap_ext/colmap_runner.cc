#include "colmap_ext/colmap_runner.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <sstream>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/timer.h"

extern char** environ;

namespace pano4d {

std::optional<std::filesystem::path> FindOnPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return std::nullopt;
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    // An empty PATH entry means the current directory.
    const std::filesystem::path candidate =
        (dir.empty() ? std::filesystem::path(".")
                     : std::filesystem::path(dir)) /
        name;
    if (::access(candidate.c_str(), X_OK) == 0 &&
        !std::filesystem::is_directory(candidate))
      return candidate;
  }
  return std::nullopt;
}

std::string LastLines(const std::filesystem::path& path, int count) {
  std::ifstream in(path);
  std::deque<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    lines.push_back(line);
    if (static_cast<int>(lines.size()) > count) lines.pop_front();
  }
  std::string out;
  for (const std::string& l : lines) out += (out.empty() ? "" : "\n") + l;
  return out;
}

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
  EnsureDirectory(log.parent_path());
  std::vector<std::string> argv_strings = {executable_.string(), subcommand};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);

  {
    // The command line heads the log, so that the step can be rerun by hand.
    std::ofstream header(log, std::ios::trunc);
    if (!header) throw Error::In(log.string(), "cannot write the log file");
    header << "$";
    for (const std::string& s : argv_strings) header << " " << s;
    header << "\n";
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null",
                                   O_RDONLY, 0);
  const Timer timer;
  pid_t pid = 0;
  const int spawn_error = posix_spawn(&pid, executable_.c_str(), &actions,
                                      nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawn_error != 0) {
    throw Error(executable_.string(), subcommand, "",
                std::string("cannot start: ") + std::strerror(spawn_error));
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      throw Error(executable_.string(), subcommand, "",
                  std::string("waitpid failed: ") + std::strerror(errno));
    }
  }
  ColmapRun run{subcommand, log, timer.WallSeconds()};
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return run;
  const std::string how =
      WIFEXITED(status)
          ? "exit status " + std::to_string(WEXITSTATUS(status))
          : "killed by signal " + std::to_string(WTERMSIG(status));
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
