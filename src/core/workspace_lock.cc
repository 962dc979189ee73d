#include "src/core/workspace_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <sstream>

#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/workspace.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

std::string& CommandLine() {
  static std::string line = "pano4d";
  return line;
}

// What the lock file says about its last holder, for a refusal.
std::string HolderOf(int fd) {
  char buffer[4096] = {};
  const ssize_t n = pread(fd, buffer, sizeof(buffer) - 1, 0);
  if (n <= 0) return "another process";
  const nlohmann::json j = nlohmann::json::parse(buffer, buffer + n, nullptr,
                                                 /*allow_exceptions=*/false);
  if (!j.is_object()) return "another process";
  std::ostringstream holder;
  holder << '`' << j.value("command", std::string("pano4d")) << "` (PID "
         << j.value("pid", 0) << " on " << j.value("host", std::string("?"))
         << ", since " << j.value("since", std::string("?")) << ")";
  return holder.str();
}

// Attempts at a lock whose file a finishing holder removed meanwhile.
constexpr int kMaxLockAttempts = 100;

std::string Now() {
  const std::time_t t = std::time(nullptr);
  std::tm local{};
  localtime_r(&t, &local);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M:%S", &local);
  return text;
}

}  // namespace

FolderLock::FolderLock(const fs::path& file, Mode mode,
                       const std::string& command)
    : file_(file) {
  for (fs::path dir = fs::absolute(file).parent_path();
       !dir.empty() && !fs::exists(dir) && dir != dir.parent_path();
       dir = dir.parent_path())
    created_.push_back(dir);
  EnsureDirectory(file.parent_path());
  const int how = mode == Mode::kExclusive ? LOCK_EX : LOCK_SH;
  int result = 0;
  // A holder that ends removes the file it created (see ~FolderLock): a
  // lock taken on a file that is no longer at `file` is taken again.
  for (int attempt = 0;; ++attempt) {
    // O_CLOEXEC: a child process (COLMAP, a prior command) must not hold
    // it.
    fd_ = open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) {
      throw Error::In(file.string(), std::string("cannot open the lock: ") +
                                         std::strerror(errno));
    }
    do {
      result = flock(fd_, how | LOCK_NB);
    } while (result != 0 && errno == EINTR);
    struct stat opened {
    }, named{};
    if (result != 0 || attempt >= kMaxLockAttempts ||
        (fstat(fd_, &opened) == 0 && stat(file.c_str(), &named) == 0 &&
         opened.st_ino == named.st_ino && opened.st_dev == named.st_dev))
      break;
    close(fd_);
  }
  if (result != 0) {
    const int why = errno;
    const std::string holder = HolderOf(fd_);
    close(fd_);
    fd_ = -1;
    if (why != EWOULDBLOCK) {
      throw Error::In(file.string(), std::string("cannot take the lock: ") +
                                         std::strerror(why));
    }
    throw Error::In(file.string(),
                    "in use by " + holder +
                        ", which writes here; wait until it ends, or stop it "
                        "(kill -INT with its PID saves what it has), then run "
                        "this again");
  }
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  const std::string text =
      nlohmann::json(
          {{"command", command},
           {"pid", static_cast<int>(getpid())},
           {"host", host},
           {"since", Now()},
           {"mode", mode == Mode::kExclusive ? "exclusive" : "shared"}})
          .dump() +
      "\n";
  // The holder's note, for a refusal's message only: a failure to write it
  // leaves the lock held and the note older.
  if (ftruncate(fd_, 0) == 0) (void)!pwrite(fd_, text.data(), text.size(), 0);
}

FolderLock::~FolderLock() {
  if (fd_ < 0) return;
  if (!created_.empty()) {
    // Removed while held, so that no one else holds it; a later command
    // creates it again.
    std::error_code ec;
    fs::remove(file_, ec);
    for (const fs::path& dir : created_) {
      if (!fs::is_empty(dir, ec) || ec) break;
      fs::remove(dir, ec);
    }
  }
  close(fd_);  // releases the flock
}

fs::path WorkspaceLockFile(const fs::path& workspace) {
  return Workspace(workspace).pano4d() / "lock";
}

FolderLock LockWorkspace(const fs::path& workspace, FolderLock::Mode mode) {
  if (mode == FolderLock::Mode::kShared &&
      !fs::is_directory(Workspace(workspace).pano4d()))
    return FolderLock();
  return FolderLock(WorkspaceLockFile(workspace), mode, ThisCommandLine());
}

const std::string& ThisCommandLine() { return CommandLine(); }

void SetThisCommandLine(int argc, char** argv) {
  std::string line;
  for (int i = 0; i < argc; ++i) {
    std::string arg = i == 0 ? fs::path(argv[i]).filename().string() : argv[i];
    if (arg.find_first_of(" \t'\"") != std::string::npos) arg = "'" + arg + "'";
    if (i > 0) line += ' ';
    line += arg;
  }
  CommandLine() = line.substr(0, 1000);
}

}  // namespace pano4d
