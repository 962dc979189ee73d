#include "src/core/subprocess.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

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
namespace fs = std::filesystem;

std::optional<fs::path> FindOnPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return std::nullopt;
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    // An empty PATH entry means the current directory.
    const fs::path candidate =
        (dir.empty() ? fs::path(".") : fs::path(dir)) / name;
    if (::access(candidate.c_str(), X_OK) == 0 && !fs::is_directory(candidate))
      return candidate;
  }
  return std::nullopt;
}

std::string ProcessResult::How() const {
  return signal != 0 ? "killed by signal " + std::to_string(signal)
                     : "exit status " + std::to_string(exit_code);
}

ProcessResult RunProcess(const std::vector<std::string>& argv_strings,
                         const fs::path& log) {
  if (argv_strings.empty())
    throw Error("RunProcess", "argv", "", "no executable given");
  EnsureDirectory(log.parent_path());
  {
    std::ofstream header(log, std::ios::trunc);
    if (!header) throw Error::In(log.string(), "cannot write the log file");
    header << "$";
    for (const std::string& s : argv_strings) header << " " << s;
    header << "\n";
  }
  std::vector<std::string> copies = argv_strings;
  std::vector<char*> argv;
  for (std::string& s : copies) argv.push_back(s.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null",
                                   O_RDONLY, 0);
  const Timer timer;
  pid_t pid = 0;
  const int spawn_error =
      posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawn_error != 0) {
    throw Error(argv_strings[0], "", "",
                std::string("cannot start: ") + std::strerror(spawn_error));
  }
  int status = 0;
  rusage usage{};
  while (wait4(pid, &status, 0, &usage) < 0) {
    if (errno != EINTR) {
      throw Error(argv_strings[0], "", "",
                  std::string("wait4 failed: ") + std::strerror(errno));
    }
  }
  ProcessResult r;
  r.seconds = timer.WallSeconds();
  r.peak_memory_mib = usage.ru_maxrss / 1024.0;  // Linux: kilobytes
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  return r;
}

std::string LastLines(const fs::path& path, int count) {
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

}  // namespace pano4d
