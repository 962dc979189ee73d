#include "src/core/stamp.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;

void Write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// Sets a file's modification time `seconds` later than it is, as an edit
// within the file system's timestamp resolution could not.
void Touch(const fs::path& path, int seconds) {
  fs::last_write_time(
      path, fs::last_write_time(path) + std::chrono::seconds(seconds));
}

TEST(StampTest, NamesTheFirstOptionOrFileThatDiffers) {
  testing::TempDir dir;
  const fs::path data = dir / "data";
  Write(data / "a.png", "aaaa");
  Write(data / "sub" / "b.npy", "bb");
  const auto inputs = [&](int factor) {
    StageRecord in(dir / "ws");
    in.Option("factor", factor).File(data).File(dir / "ws" / "frames.json");
    return in.json();
  };
  const nlohmann::json before = inputs(2);
  EXPECT_EQ(RecordDifference(before, inputs(2)), std::nullopt);
  EXPECT_EQ(RecordDifference(before, inputs(1)).value_or(""),
            "option factor was 2, now 1");

  Write(data / "a.png", "aaab");  // same size: the modification time tells
  Touch(data / "a.png", 5);
  const std::string changed = RecordDifference(before, inputs(2)).value_or("");
  EXPECT_NE(changed.find("a.png changed"), std::string::npos) << changed;

  const nlohmann::json now = inputs(2);
  Write(data / "c.png", "c");
  EXPECT_NE(RecordDifference(now, inputs(2)).value_or("").find("c.png is new"),
            std::string::npos);
  fs::remove(data / "c.png");
  fs::remove(data / "sub" / "b.npy");
  EXPECT_NE(RecordDifference(now, inputs(2)).value_or("").find("b.npy is gone"),
            std::string::npos);
  // A workspace file is keyed relative to the workspace; a missing one is
  // recorded, and its appearance noticed.
  EXPECT_TRUE(now["files"].contains("frames.json"));
  EXPECT_TRUE(now["files"]["frames.json"].is_null());
  Write(dir / "ws" / "frames.json", "{}");
  EXPECT_NE(RecordDifference(now, inputs(2)).value_or("").find("frames.json"),
            std::string::npos);
}

TEST(StampTest, AWorkspaceInsideAnInputFolderIsNotItsInput) {
  testing::TempDir dir;
  Write(dir / "dataset" / "a.png", "a");
  Write(dir / "dataset" / "ws" / "pano4d" / "frames.json", "{}");
  StageRecord in(dir / "dataset" / "ws");
  in.File(dir / "dataset");
  EXPECT_EQ(in.json()["files"].size(), 1u) << in.json().dump();
}

TEST(StampTest, AStampIsWrittenOnCompletionAndRemovedAtTheStart) {
  testing::TempDir dir;
  const Workspace ws(dir / "ws");
  Write(dir / "in.txt", "x");
  StageRecord in(ws.root());
  in.File(dir / "in.txt");
  const StageStamp stamp(ws, "depth");
  EXPECT_NE(stamp.StaleReason(in).value_or("").find("not completed"),
            std::string::npos);
  stamp.Write(in);
  EXPECT_TRUE(fs::exists(ws.stamps() / "depth.json"));
  EXPECT_EQ(stamp.StaleReason(in), std::nullopt);
  stamp.Remove();
  EXPECT_TRUE(stamp.StaleReason(in).has_value());
  Write(ws.stamps() / "depth.json", "not json");
  EXPECT_NE(stamp.StaleReason(in).value_or("").find("not a stamp"),
            std::string::npos);
}

// What a stage holds in memory is compared by fingerprint and named; what
// it wrote must still exist; Decide says the same for every stage and a
// forced reason wins over the stamp.
TEST(StampTest, ContentsOutputsAndTheDecision) {
  testing::TempDir dir;
  const Workspace ws(dir / "ws");
  Write(ws.root() / "out" / "model.bin", "m");
  const auto record = [&](const std::string& frames) {
    StageRecord r(ws.root());
    r.Option("iterations", 10)
        .Content("the training frames", frames)
        .Output(ws.root() / "out");
    return r;
  };
  EXPECT_EQ(record("a").json()["outputs"], nlohmann::json::array({"out"}));
  EXPECT_EQ(RecordDifference(record("a").json(), record("b").json()),
            "the training frames changed");
  const StageStamp stamp(ws, "sfm/mapper");
  stamp.Write(record("a"), 12.5);
  EXPECT_TRUE(fs::exists(ws.stamps() / "sfm" / "mapper.json"));
  EXPECT_DOUBLE_EQ(stamp.Seconds(), 12.5);
  EXPECT_EQ(stamp.Decide(record("a")), std::nullopt);
  EXPECT_EQ(stamp.Decide(record("a"), "--force"), "--force");
  EXPECT_EQ(stamp.Decide(record("b")), "the training frames changed");
  fs::remove_all(ws.root() / "out");
  EXPECT_EQ(stamp.StaleReason(record("a")), "its output out is gone");
  // A stamp written before contents and outputs were recorded still
  // matches a record without them.
  Write(ws.stamps() / "old.json", R"({"options": {}, "files": {}})");
  EXPECT_EQ(StageStamp(ws, "old").StaleReason(StageRecord(ws.root())),
            std::nullopt);
  EXPECT_DOUBLE_EQ(StageStamp(ws, "old").Seconds(), 0.0);
}

}  // namespace
}  // namespace pano4d
