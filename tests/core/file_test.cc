#include "src/core/file.h"

#include <sys/wait.h>
#include <unistd.h>

#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

using testing::SmallDisk;
using testing::TempDir;

int CountEntries(const std::filesystem::path& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& entry :
       std::filesystem::directory_iterator(dir))
    ++n;
  return n;
}

TEST(FileTest, TemporaryPathKeepsDirectoryAndExtension) {
  const std::filesystem::path tmp = TemporaryPathFor("out/frame_0001.png");
  EXPECT_EQ(tmp.parent_path(), "out");
  EXPECT_EQ(tmp.extension(), ".png");
  EXPECT_NE(tmp.filename(), "frame_0001.png");
  EXPECT_NE(TemporaryPathFor("out/frame_0001.png"), tmp);
}

TEST(FileTest, AtomicWriteReplacesAndLeavesNoTemporary) {
  TempDir dir;
  const auto path = dir / "sub" / "a.txt";
  WriteFileAtomically(path, "first");
  WriteFileAtomically(path, "second");
  EXPECT_EQ(ReadTextFile(path), "second");
  EXPECT_EQ(CountEntries(dir / "sub"), 1);
}

TEST(FileTest, LeftoverTemporariesOfDeadProcessesAreRemoved) {
  TempDir dir;
  // The id of a process that has ended: a child that exits at once.
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) ::_exit(0);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  const std::string dead = std::to_string(child);
  const std::string live = std::to_string(::getpid());
  std::filesystem::create_directories(dir / "sub");
  const std::vector<std::filesystem::path> leftovers = {
      dir / ("fit.tmp." + dead + ".0.ckpt"),
      dir / "sub" / ("00001.tmp." + dead + ".12.png"),
      dir / "sub" / ("noext.tmp." + dead + ".3")};
  const std::vector<std::filesystem::path> kept = {
      dir / ("fit.tmp." + live + ".1.ckpt"),  // its writer still runs
      dir / "fit.ckpt", dir / "sub" / "a.tmp.png", dir / "sub" / "tmp.5.6",
      dir / "big.tmp.99999999999999999999.1.png"};  // no such id
  for (const auto& p : leftovers) WriteFileAtomically(p, "x");
  for (const auto& p : kept) WriteFileAtomically(p, "x");
  EXPECT_EQ(RemoveLeftoverTemporaries(dir.path()), 3);
  for (const auto& p : leftovers) EXPECT_FALSE(std::filesystem::exists(p)) << p;
  for (const auto& p : kept) EXPECT_TRUE(std::filesystem::exists(p)) << p;
  EXPECT_EQ(RemoveLeftoverTemporaries(dir / "missing"), 0);
}

// A folder being written says so until it is complete, and an earlier
// output's numbered files go first (a shorter new output leaves none).
TEST(FileTest, AnOutputFolderIsMarkedIncompleteUntilDone) {
  TempDir dir;
  const std::filesystem::path out = dir / "export";
  WriteFileAtomically(out / "ply" / "t_00007.ply", "old");
  WriteFileAtomically(out / "notes.txt", "the user's");
  {
    OutputFolder folder(out, "pano4d export", R"(ply/t_[0-9]+\.ply)");
    EXPECT_TRUE(std::filesystem::exists(out / OutputFolder::kMarker));
    EXPECT_NE(ReadTextFile(out / OutputFolder::kMarker).find("pano4d export"),
              std::string::npos);
    EXPECT_FALSE(std::filesystem::exists(out / "ply" / "t_00007.ply"));
    EXPECT_TRUE(std::filesystem::exists(out / "notes.txt"));
    // Killed here: the marker stays.
  }
  EXPECT_TRUE(std::filesystem::exists(out / OutputFolder::kMarker));
  OutputFolder again(out, "pano4d export");
  again.Complete();
  EXPECT_FALSE(std::filesystem::exists(out / OutputFolder::kMarker));
}

TEST(FileTest, FailedWriteKeepsThePreviousVersion) {
  TempDir dir;
  const auto path = dir / "checkpoint.bin";
  WriteFileAtomically(path, "good");
  EXPECT_THROW(WriteAtomically(path,
                               [](const std::filesystem::path& tmp) {
                                 WriteFileAtomically(tmp, "partial");
                                 throw Error::In(tmp.string(),
                                                 "killed half way");
                               }),
               Error);
  EXPECT_EQ(ReadTextFile(path), "good");
  EXPECT_EQ(CountEntries(dir.path()), 1);
}

// A disk that fills up for real: the write fails naming the file and
// saying the disk is full (a copy through sendfile reports only
// "Input/output error"), and the earlier version stays.
TEST(FileTest, AFullDiskIsNamedAsSuchAndKeepsThePreviousVersion) {
  SmallDisk disk(256);
  if (!disk.mounted()) GTEST_SKIP() << "SMALL DISK UNAVAILABLE: " << disk.why();
  const auto path = disk / "scene.bin";
  WriteFileAtomically(path, "good");
  const std::string big(1 << 20, 'x');
  TempDir elsewhere;
  WriteFileAtomically(elsewhere / "big.bin", big);
  const std::vector<std::function<void()>> writes = {
      [&] { WriteFileAtomically(path, big); },
      [&] {
        WriteAtomically(path, [&](const std::filesystem::path& tmp) {
          std::filesystem::copy_file(elsewhere / "big.bin", tmp);
        });
      }};
  for (const auto& write : writes) {
    try {
      write();
      ADD_FAILURE() << "a 1 MiB write fitted on a 256 KiB disk";
    } catch (const Error& e) {
      EXPECT_EQ(e.source(), path.string());
      EXPECT_NE(e.problem().find("the disk holding it is full"),
                std::string::npos)
          << e.what();
    }
    EXPECT_EQ(ReadTextFile(path), "good");
    EXPECT_EQ(CountEntries(disk.path()), 1);
  }
}

TEST(FileTest, ReadErrorsNameThePath) {
  TempDir dir;
  try {
    ReadFileBytes(dir / "missing.bin");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), (dir / "missing.bin").string());
    EXPECT_EQ(e.problem(), "does not exist");
  }
  EXPECT_THROW(ReadFileBytes(dir.path()), Error);
}

}  // namespace
}  // namespace pano4d
