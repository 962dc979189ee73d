#include "src/core/frames.h"

#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/workspace.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

WorkspaceFrames TwoFrames() {
  WorkspaceFrames frames;
  for (int t = 0; t < 2; ++t) {
    WorkspaceFrame f;
    f.name = "0_0000" + std::to_string(t);
    f.time = t;
    f.camera.camera = Camera{CameraModelId::kPinhole, 8, 6, {5, 5, 4, 3}};
    frames.train.push_back(f);
  }
  frames.num_times = 2;
  return frames;
}

// The field of the Error that Check throws ("" when none).
std::string CheckField(const WorkspaceFrames& frames) {
  try {
    frames.Check("frames.json");
  } catch (const Error& e) {
    return e.field();
  }
  return "";
}

TEST(FramesTest, CheckBoundsTimesByTheFrames) {
  WorkspaceFrames frames = TwoFrames();
  EXPECT_EQ(CheckField(frames), "");
  frames.num_times = 100000;  // would hang the motion model's setup
  EXPECT_EQ(CheckField(frames), "num_times");
  frames.num_times = 0;
  EXPECT_EQ(CheckField(frames), "num_times");
  frames = TwoFrames();
  frames.train[1].time = 2;
  EXPECT_EQ(CheckField(frames), "frame 0_00001 time");
  frames = TwoFrames();
  frames.train[1].name = frames.train[0].name;
  EXPECT_EQ(CheckField(frames), "name");
}

// Frame names become file names in the workspace (renders/val/<name>.png):
// a frames.json from someone else may not make pano4d write outside it.
// Each refusal names the file and the field.
TEST(FramesTest, AFramesFileThatNamesPathsOrCorruptPosesIsRefused) {
  testing::TempDir dir;
  const std::filesystem::path ws = dir / "ws";
  WorkspaceFrames frames = TwoFrames();
  frames.val.push_back(frames.train[1]);
  frames.val[0].name = "v_00000";
  WriteWorkspaceFrames(ws, frames);
  const std::filesystem::path file = Workspace(ws).frames_json();
  const Json good = ReadJson(file);
  ASSERT_EQ(ReadWorkspaceFrames(ws).val.size(), 1u);
  const std::string long_name(300, 'a');
  struct Case {
    const char* split;
    const char* key;
    Json value;
    std::string field;
  };
  for (const Case& c :
       std::vector<Case>{{"val", "name", "/tmp/x/absval", "name"},
                         {"val", "name", "../../../x", "name"},
                         {"train", "name", "..", "name"},
                         {"train", "name", "", "name"},
                         {"train", "name", long_name, "name"},
                         {"train", "qvec", Json({0, 0, 0, 0}), "qvec"},
                         {"train", "tvec", Json({1e300, 0, 0}), "tvec"}}) {
    Json bad = good;
    bad[c.split][0][c.key] = c.value;
    WriteJson(file, bad);
    try {
      ReadWorkspaceFrames(ws);
      ADD_FAILURE() << c.key << " " << c.value.dump().substr(0, 40)
                    << " was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), c.field) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace pano4d
