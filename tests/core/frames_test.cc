#include "src/core/frames.h"

#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"

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

}  // namespace
}  // namespace pano4d
