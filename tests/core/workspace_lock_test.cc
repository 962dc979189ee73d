#include "src/core/workspace_lock.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using Mode = FolderLock::Mode;

// The message of the Error taking the lock throws ("" when it is taken).
std::string Refusal(const fs::path& file, Mode mode) {
  try {
    const FolderLock lock(file, mode, "pano4d second");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// flock locks belong to an open file: a second lock of the same file in
// this process conflicts as another process's would.
TEST(FolderLockTest, WritersExcludeEveryoneReadersShare) {
  testing::TempDir dir;
  const fs::path file = dir / "ws" / "pano4d" / "lock";
  {
    const FolderLock writer(file, Mode::kExclusive,
                            "pano4d fit --workspace ws");
    const std::string refused = Refusal(file, Mode::kExclusive);
    EXPECT_NE(refused.find("pano4d fit --workspace ws"), std::string::npos)
        << refused;
    EXPECT_NE(refused.find("PID " + std::to_string(getpid())),
              std::string::npos)
        << refused;
    EXPECT_NE(refused.find(file.string()), std::string::npos) << refused;
    EXPECT_NE(Refusal(file, Mode::kShared), "");
  }
  {
    const FolderLock reader(file, Mode::kShared, "pano4d render");
    EXPECT_NE(Refusal(file, Mode::kExclusive).find("pano4d render"),
              std::string::npos);
    EXPECT_EQ(Refusal(file, Mode::kShared), "");
    // The note names the reader that came last.
    EXPECT_NE(Refusal(file, Mode::kExclusive).find("pano4d second"),
              std::string::npos);
  }
  EXPECT_EQ(Refusal(file, Mode::kExclusive), "");  // released
}

TEST(FolderLockTest, AKilledHoldersLockIsTakenOver) {
  testing::TempDir dir;
  const fs::path file = dir / "lock";
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const FolderLock lock(file, Mode::kExclusive, "pano4d fit (child)");
    const char byte = 1;
    (void)!write(ready[1], &byte, 1);
    pause();  // until SIGKILL
    _exit(0);
  }
  char byte = 0;
  ASSERT_EQ(read(ready[0], &byte, 1), 1);
  const std::string refused = Refusal(file, Mode::kExclusive);
  EXPECT_NE(refused.find("PID " + std::to_string(child)), std::string::npos)
      << refused;
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(Refusal(file, Mode::kExclusive), "");
  close(ready[0]);
  close(ready[1]);
}

// A reader of a workspace that is not there takes no lock and creates
// nothing; a writer creates the workspace's folder for its lock, and
// removes it again when it wrote nothing there (a refused command leaves
// no workspace), but not a workspace it wrote to.
TEST(FolderLockTest, LockWorkspaceCreatesOnlyForWriters) {
  testing::TempDir dir;
  { const FolderLock reader = LockWorkspace(dir / "none", Mode::kShared); }
  EXPECT_FALSE(fs::exists(dir / "none"));
  {
    const FolderLock writer = LockWorkspace(dir / "ws");
    EXPECT_TRUE(fs::exists(WorkspaceLockFile(dir / "ws")));
    EXPECT_NE(Refusal(WorkspaceLockFile(dir / "ws"), Mode::kExclusive), "");
  }
  EXPECT_FALSE(fs::exists(dir / "ws"));
  {
    const FolderLock writer = LockWorkspace(dir / "ws");
    testing::WriteText(dir / "ws" / "pano4d" / "frames.json", "{}");
  }
  EXPECT_TRUE(fs::exists(dir / "ws" / "pano4d" / "frames.json"));
  EXPECT_EQ(Refusal(WorkspaceLockFile(dir / "ws"), Mode::kExclusive), "");
}

}  // namespace
}  // namespace pano4d
