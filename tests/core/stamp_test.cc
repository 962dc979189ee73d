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
  fs::last_write_time(path,
                      fs::last_write_time(path) + std::chrono::seconds(seconds));
}

TEST(StampTest, NamesTheFirstOptionOrFileThatDiffers) {
  testing::TempDir dir;
  const fs::path data = dir / "data";
  Write(data / "a.png", "aaaa");
  Write(data / "sub" / "b.npy", "bb");
  const auto inputs = [&](int factor) {
    StageInputs in(dir / "ws");
    in.Option("factor", factor).File(data).File(dir / "ws" / "frames.json");
    return in.json();
  };
  const nlohmann::json before = inputs(2);
  EXPECT_EQ(InputsDifference(before, inputs(2)), std::nullopt);
  EXPECT_EQ(InputsDifference(before, inputs(1)).value_or(""),
            "option factor was 2, now 1");

  Write(data / "a.png", "aaab");  // same size: the modification time tells
  Touch(data / "a.png", 5);
  const std::string changed = InputsDifference(before, inputs(2)).value_or("");
  EXPECT_NE(changed.find("a.png changed"), std::string::npos) << changed;

  const nlohmann::json now = inputs(2);
  Write(data / "c.png", "c");
  EXPECT_NE(InputsDifference(now, inputs(2)).value_or("").find("c.png is new"),
            std::string::npos);
  fs::remove(data / "c.png");
  fs::remove(data / "sub" / "b.npy");
  EXPECT_NE(InputsDifference(now, inputs(2)).value_or("").find("b.npy is gone"),
            std::string::npos);
  // A workspace file is keyed relative to the workspace; a missing one is
  // recorded, and its appearance noticed.
  EXPECT_TRUE(now["files"].contains("frames.json"));
  EXPECT_TRUE(now["files"]["frames.json"].is_null());
  Write(dir / "ws" / "frames.json", "{}");
  EXPECT_NE(InputsDifference(now, inputs(2)).value_or("").find("frames.json"),
            std::string::npos);
}

TEST(StampTest, AWorkspaceInsideAnInputFolderIsNotItsInput) {
  testing::TempDir dir;
  Write(dir / "dataset" / "a.png", "a");
  Write(dir / "dataset" / "ws" / "pano4d" / "frames.json", "{}");
  StageInputs in(dir / "dataset" / "ws");
  in.File(dir / "dataset");
  EXPECT_EQ(in.json()["files"].size(), 1u) << in.json().dump();
}

TEST(StampTest, AStampIsWrittenOnCompletionAndRemovedAtTheStart) {
  testing::TempDir dir;
  const Workspace ws(dir / "ws");
  Write(dir / "in.txt", "x");
  StageInputs in(ws.root());
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

}  // namespace
}  // namespace pano4d
