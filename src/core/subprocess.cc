#include "src/core/subprocess.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <optional>
#include <sstream>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/stop_signal.h"
#include "src/core/strings.h"
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
  if (timed_out)
    return StringPrintf("stopped at its time limit of %g s", time_limit_s);
  if (signal != 0) return "killed by signal " + std::to_string(signal);
  // 127 is the shell's "command not found".
  return "exit status " + std::to_string(exit_code) +
         (exit_code == 127 ? " (command not found?)" : "");
}

namespace {

// The first of the signals below that pano4d received while a child of its
// own group ran, or 0.
volatile std::sig_atomic_t g_received = 0;

void Remember(int signal) {
  if (g_received == 0) g_received = signal;
}

// `handler` for each of `signals` except those pano4d ignores (`nohup`, a
// background job's SIGINT), which stay ignored; the previous actions go
// to `old`, for RestoreHandlers.
template <std::size_t N>
void InstallUnlessIgnored(const int (&signals)[N], void (*handler)(int),
                          struct sigaction (&old)[N]) {
  struct sigaction action {};
  action.sa_handler = handler;
  sigemptyset(&action.sa_mask);
  for (std::size_t i = 0; i < N; ++i) {
    sigaction(signals[i], nullptr, &old[i]);
    if (old[i].sa_handler != SIG_IGN) sigaction(signals[i], &action, nullptr);
  }
}

template <std::size_t N>
void RestoreHandlers(const int (&signals)[N],
                     const struct sigaction (&old)[N]) {
  for (std::size_t i = 0; i < N; ++i) sigaction(signals[i], &old[i], nullptr);
}

// What ends pano4d from outside: Ctrl-C, kill, a closed terminal, Ctrl-\.
// A child in its own group hears none of them by itself.
constexpr int kPassedSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
constexpr int kSignalCount = sizeof(kPassedSignals) / sizeof(int);

// While alive: the signals above are remembered, not acted on, except
// those pano4d ignores (`nohup`, a background job's SIGINT), which stay
// ignored; the previous actions come back at the end.
class SignalsRemembered {
 public:
  SignalsRemembered() {
    g_received = 0;
    InstallUnlessIgnored(kPassedSignals, Remember, old_);
  }
  ~SignalsRemembered() { RestoreHandlers(kPassedSignals, old_); }

 private:
  struct sigaction old_[kSignalCount] {};
};

// Polls the child every this many milliseconds while it may have to be
// stopped (a time limit, a signal to pass on).
constexpr int kPollMilliseconds = 10;

// Waits for `pid`; nullopt when `seconds` passed first or, with
// `stop_on_signal`, a signal was remembered.
std::optional<int> WaitFor(pid_t pid, double seconds, bool stop_on_signal,
                           rusage* usage, const std::string& what) {
  const Timer timer;
  int status = 0;
  while (true) {
    const pid_t done = wait4(pid, &status, WNOHANG, usage);
    if (done == pid) return status;
    if (done < 0 && errno != EINTR) {
      throw Error(what, "", "",
                  std::string("wait4 failed: ") + std::strerror(errno));
    }
    if ((stop_on_signal && g_received != 0) ||
        (seconds >= 0 && timer.WallSeconds() > seconds))
      return std::nullopt;
    ::usleep(kPollMilliseconds * 1000);
  }
}

// Stops the group `pid` leads: SIGTERM, then SIGKILL after the grace (or
// at once when a signal arrives during it), and reaps the child.
int StopGroup(pid_t pid, rusage* usage, const std::string& what) {
  const bool signalled = g_received != 0;
  ::kill(-pid, SIGTERM);
  std::optional<int> status = WaitFor(
      pid, kStopGraceSeconds, /*stop_on_signal=*/!signalled, usage, what);
  ::kill(-pid, SIGKILL);  // the child, if still there, and what it left
  if (!status) {
    int raw = 0;
    while (wait4(pid, &raw, 0, usage) < 0) {
      if (errno != EINTR) {
        throw Error(what, "", "",
                    std::string("wait4 failed: ") + std::strerror(errno));
      }
    }
    status = raw;
  }
  return *status;
}

// The signal a SignalsForwarded scope received, or 0.
volatile std::sig_atomic_t g_forward = 0;
constexpr int kForwardedSignals[] = {SIGINT, SIGTERM, SIGHUP};

void RememberForForwarding(int signal) {
  if (g_forward == 0) g_forward = signal;
}

// Waits for `pid`, passing on the stop signal and a forwarded one once
// each as they arrive.
int WaitForwarding(pid_t pid, rusage* usage, const std::string& what) {
  bool stop_sent = false, forward_sent = false;
  int status = 0;
  while (true) {
    const pid_t done = wait4(pid, &status, WNOHANG, usage);
    if (done == pid) return status;
    if (done < 0 && errno != EINTR) {
      throw Error(what, "", "",
                  std::string("wait4 failed: ") + std::strerror(errno));
    }
    if (!stop_sent && StopRequested()) {
      ::kill(pid, StopSignal());
      stop_sent = true;
    }
    if (!forward_sent && g_forward != 0) {
      ::kill(pid, g_forward);
      forward_sent = true;
    }
    ::usleep(kPollMilliseconds * 1000);
  }
}

}  // namespace

SignalsForwarded::SignalsForwarded() {
  g_forward = 0;
  InstallUnlessIgnored(kForwardedSignals, RememberForForwarding, old_);
}

SignalsForwarded::~SignalsForwarded() {
  RestoreHandlers(kForwardedSignals, old_);
  const int received = g_forward;
  g_forward = 0;
  if (received != 0) std::raise(received);
}

int SignalsForwarded::Received() { return g_forward; }

namespace {

void CheckProcessOptions(const std::vector<std::string>& argv,
                         const ProcessOptions& options) {
  if (argv.empty())
    throw Error("RunProcess", "argv", "", "no executable given");
  if (options.forward_signals && options.own_group) {
    throw Error("RunProcess", "forward_signals", "true",
                "a child in its own group is stopped, not forwarded to");
  }
  if (options.timeout_seconds > 0 && !options.own_group) {
    throw Error("RunProcess", "timeout_seconds",
                std::to_string(options.timeout_seconds),
                "a time limit stops the child's own process group: set "
                "own_group");
  }
}

// Starts argv with stdout and stderr appended to `log` (which begins with
// the command line) and stdin from /dev/null, in its own process group when
// asked. Returns its pid.
pid_t Spawn(const std::vector<std::string>& argv_strings, const fs::path& log,
            bool own_group) {
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
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  if (own_group) {
    posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attributes, 0);
  }
  pid_t pid = 0;
  const int spawn_error =
      posix_spawn(&pid, argv[0], &actions, &attributes, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  if (spawn_error != 0) {
    throw Error(argv_strings[0], "", "",
                std::string("cannot start: ") + std::strerror(spawn_error));
  }
  return pid;
}

// Waits for a child in pano4d's group, through interruptions.
int WaitPlain(pid_t pid, rusage* usage, const std::string& what) {
  int status = 0;
  while (wait4(pid, &status, 0, usage) < 0) {
    if (errno != EINTR) {
      throw Error(what, "", "",
                  std::string("wait4 failed: ") + std::strerror(errno));
    }
  }
  return status;
}

}  // namespace

ProcessResult RunProcess(const std::vector<std::string>& argv_strings,
                         const fs::path& log, const ProcessOptions& options) {
  CheckProcessOptions(argv_strings, options);
  std::optional<SignalsRemembered> remembered;
  if (options.own_group) remembered.emplace();
  const Timer timer;
  const pid_t pid = Spawn(argv_strings, log, options.own_group);
  const std::string& what = argv_strings[0];
  int status = 0;
  rusage usage{};
  ProcessResult r;
  if (options.forward_signals) {
    status = WaitForwarding(pid, &usage, what);
  } else if (!options.own_group) {
    status = WaitPlain(pid, &usage, what);
  } else {
    const double limit =
        options.timeout_seconds > 0 ? options.timeout_seconds : -1.0;
    if (const std::optional<int> done =
            WaitFor(pid, limit, /*stop_on_signal=*/true, &usage, what)) {
      status = *done;
    } else {
      r.timed_out = g_received == 0;
      r.time_limit_s = options.timeout_seconds;
      status = StopGroup(pid, &usage, what);
    }
    const int received = g_received;
    remembered.reset();
    // A signal while the child ran: the child's group is stopped; now
    // pano4d ends as the signal would have ended it.
    if (received != 0) std::raise(received);
  }
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

std::string ProcessFailure(const ProcessResult& result, const fs::path& log) {
  std::istringstream lines(LastLines(log, 40));
  std::string line, why, last;
  while (std::getline(lines, line)) {
    // RunProcess heads the log with the command line ("$ ...").
    if (line.rfind("$ ", 0) == 0) continue;
    last = line;
    std::string lower = line;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (lower.find("error") != std::string::npos ||
        lower.find("failed") != std::string::npos)
      why = line;
  }
  if (why.empty()) why = last;
  if (why.size() > kQuotedLogChars)
    why = why.substr(0, kQuotedLogChars) + "...";
  std::string text = result.How();
  if (!why.empty()) text += ": \"" + why + "\"";
  return text + " (log: " + log.string() + ")";
}

}  // namespace pano4d
