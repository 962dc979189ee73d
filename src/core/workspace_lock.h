#pragma once

// An advisory lock on a workspace (or any folder pano4d writes into), so
// that two commands never write one workspace at once: `fit` twice, `run`
// beside `fit --force`, two `sweep run` of one entry. The lock is flock(2)
// on a file in the folder, so the kernel releases it whenever its process
// ends, SIGKILL included, and the next command takes it over without a
// stale-lock check; the file holds the holder's command, PID, host and
// start time for the refusal's message.

#include <filesystem>
#include <string>
#include <vector>

namespace pano4d {

class FolderLock {
 public:
  enum class Mode {
    kExclusive,  // writers: sfm, depth, fit, expand, run, sweep run
    kShared,     // readers: render, export, view (many at once)
  };

  // Takes the lock on `file` (created, with its folder) for `command`
  // (the command line, for a refusal's message). Throws pano4d::Error
  // naming the file and the holder when another process holds it in a
  // mode that excludes `mode`. Folders it created for the file are removed
  // again at the end when nothing else was written in them (a command
  // that refused its options leaves no workspace behind).

  FolderLock(const std::filesystem::path& file, Mode mode,
             const std::string& command);
  FolderLock() = default;  // holds nothing
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  int fd_ = -1;
  std::filesystem::path file_;
  std::vector<std::filesystem::path> created_;  // innermost first
};

// The lock of workspace `workspace`: WS/pano4d/lock.
std::filesystem::path WorkspaceLockFile(const std::filesystem::path& workspace);

// The workspace's lock for this process's command line. A reader (shared)
// of a workspace that does not exist takes none: the command's own
// message then names what is missing.
FolderLock LockWorkspace(const std::filesystem::path& workspace,
                         FolderLock::Mode mode = FolderLock::Mode::kExclusive);

// The command line of this process ("pano4d fit --workspace WS"), as the
// CLI set it; a lock names its holder with it.
const std::string& ThisCommandLine();
void SetThisCommandLine(int argc, char** argv);

}  // namespace pano4d
