#include "src/core/file.h"

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

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
