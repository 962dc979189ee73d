#include "colmap_ext/colmap_runner.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/file.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// A stand-in for colmap: a shell script with the given body, which
// answers `colmap help` and `colmap <command> -h` as COLMAP 3.8 taking
// --a does.
fs::path FakeColmap(const fs::path& dir, const std::string& body) {
  const fs::path path = dir / "colmap";
  std::ofstream(path)
      << "#!/bin/sh\n"
      << "case \"$1 $2\" in\n"
      << "  'help '*) echo 'COLMAP 3.8 -- Structure-from-Motion';"
         " exit 0 ;;\n"
      << "  *' -h') echo '  --a arg'; exit 0 ;;\n"
      << "esac\n"
      << body << "\n";
  fs::permissions(path, fs::perms::owner_all);
  return path;
}

TEST(ColmapRunnerTest, SuccessWritesTheCommandAndOutputToTheLog) {
  TempDir dir;
  const ColmapRunner runner(
      FakeColmap(dir.path(), "echo \"ran $1 $2 $3\"; echo oops >&2"));
  const ColmapRun run =
      runner.Run("mapper", {"--a", "b"}, dir.path() / "logs" / "mapper.log");
  EXPECT_GE(run.seconds, 0.0);
  const std::string log = ReadTextFile(dir.path() / "logs" / "mapper.log");
  EXPECT_NE(log.find("colmap mapper --a b"), std::string::npos) << log;
  EXPECT_NE(log.find("ran mapper --a b"), std::string::npos) << log;
  EXPECT_NE(log.find("oops"), std::string::npos) << log;  // stderr too
}

TEST(ColmapRunnerTest, FailureNamesStepStatusLogRemedyAndLastLines) {
  TempDir dir;
  const ColmapRunner runner(FakeColmap(
      dir.path(), "echo 'No good initial image pair found.'; exit 3"));
  const fs::path log = dir.path() / "mapper.log";
  try {
    runner.Run("mapper", {}, log, "lower --stride");
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("colmap mapper failed: exit status 3"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find(log.string()), std::string::npos) << what;
    EXPECT_NE(what.find("lower --stride"), std::string::npos) << what;
    EXPECT_NE(what.find("No good initial image pair"), std::string::npos)
        << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
  }
}

TEST(ColmapRunnerTest, KilledBySignalIsAnError) {
  TempDir dir;
  const ColmapRunner runner(FakeColmap(dir.path(), "kill -9 $$"));
  try {
    runner.Run("mapper", {}, dir.path() / "mapper.log");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("killed by signal 9"),
              std::string::npos)
        << e.what();
  }
}

TEST(ColmapRunnerTest, MissingColmapSaysHowToInstallIt) {
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  TempDir empty;
  setenv("PATH", empty.path().c_str(), 1);
  EXPECT_FALSE(FindOnPath("colmap").has_value());
  try {
    ColmapRunner runner;
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("apt-get install colmap"),
              std::string::npos)
        << e.what();
  }
  setenv("PATH", saved.c_str(), 1);
}

TEST(ColmapRunnerTest, AnExecutableThatCannotStartIsAnError) {
  TempDir dir;
  const ColmapRunner runner(dir.path() / "no-such-colmap");
  EXPECT_THROW(runner.Run("mapper", {}, dir.path() / "mapper.log"), Error);
}

TEST(ColmapRunnerTest, FindOnPathFindsExecutablesOnly) {
  TempDir dir;
  FakeColmap(dir.path(), "true");
  std::ofstream(dir.path() / "plain") << "not executable";
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  setenv("PATH", (std::string("/nonexistent:") + dir.path().string()).c_str(),
         1);
  EXPECT_EQ(FindOnPath("colmap"), dir.path() / "colmap");
  EXPECT_FALSE(FindOnPath("plain").has_value());
  setenv("PATH", saved.c_str(), 1);
}

}  // namespace
}  // namespace pano4d
