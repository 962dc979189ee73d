#include "src/core/subprocess.h"

#include <string>

#include <gtest/gtest.h>

#include "tests/support/test_files.h"

namespace pano4d {
namespace {

ProcessResult Shell(const std::string& script, const std::filesystem::path& log,
                    double timeout_s = 0) {
  return RunProcess({"/bin/sh", "-c", script}, log,
                    {.timeout_seconds = timeout_s, .own_group = true});
}

// One failure text for every child pano4d runs (COLMAP, a prior command,
// a sweep entry, a bench scene): how it ended, the log line that says why
// (the last naming an error or a failure, else the last line; never the
// command line heading the log), and the log.
TEST(ProcessFailureTest, NamesHowTheLineThatSaysWhyAndTheLog) {
  testing::TempDir dir;
  const auto log = dir / "child.log";
  ProcessResult r = Shell(
      "echo 'reading frames'; echo 'ERROR: frame 3 is corrupt'; "
      "echo 'cleaning up'; exit 2",
      log);
  EXPECT_EQ(ProcessFailure(r, log),
            "exit status 2: \"ERROR: frame 3 is corrupt\" (log: " +
                log.string() + ")");

  r = Shell("echo 'nothing special'; exit 1", dir / "plain.log");
  EXPECT_EQ(ProcessFailure(r, dir / "plain.log"),
            "exit status 1: \"nothing special\" (log: " +
                (dir / "plain.log").string() + ")");

  // Silent: no line quoted, not even the command line.
  r = Shell("exit 127", dir / "silent.log");
  EXPECT_EQ(ProcessFailure(r, dir / "silent.log"),
            "exit status 127 (command not found?) (log: " +
                (dir / "silent.log").string() + ")");

  r = Shell("kill -9 $$", dir / "killed.log");
  EXPECT_EQ(
      ProcessFailure(r, dir / "killed.log").rfind("killed by signal 9", 0), 0u);

  r = Shell("sleep 30", dir / "slow.log", /*timeout_s=*/0.2);
  EXPECT_TRUE(r.timed_out);
  EXPECT_EQ(ProcessFailure(r, dir / "slow.log")
                .rfind("stopped at its time limit of 0.2 s", 0),
            0u);
}

}  // namespace
}  // namespace pano4d
