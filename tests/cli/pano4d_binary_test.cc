// The pano4d executable as a shell sees it: exit statuses and stderr lines.
#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/test_files.h"

namespace pano4d {
namespace {

struct Result {
  int status;
  std::string err;
};

Result RunBinary(const std::string& args, const testing::TempDir& dir) {
  const std::string err_path = (dir / "stderr.txt").string();
  const std::string command = std::string(PANO4D_BINARY_DIR) + "/pano4d " +
                              args + " > /dev/null 2> '" + err_path + "'";
  const int raw = std::system(command.c_str());
  std::ifstream in(err_path);
  std::stringstream err;
  err << in.rdbuf();
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, err.str()};
}

TEST(Pano4dBinaryTest, CorruptInputsFailWithOneLineAndNonZeroStatus) {
  testing::TempDir dir;
  testing::WriteTruncatedPng(dir / "cut.png");
  testing::WriteText(dir / "fake.mp4", "these bytes are not a video");
  testing::WriteText(dir / "cam.json",
                     R"({"model": "PINHOLE", "width": 640, "height": 480,
                                           "params": [500, "500", 320, 240]})");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {(dir / "cut.png").string(),
       ": truncated PNG: the IEND chunk is missing"},
      {(dir / "cam.json").string(),
       ": field 'params[1]' = \"500\": expected a number"},
      {(dir / "gone.mp4").string(), ": does not exist"},
      {(dir / "fake.mp4").string(), ": OpenCV cannot open it as a video"},
  };
  for (const auto& [path, problem] : cases) {
    const Result r = RunBinary("inspect '" + path + "'", dir);
    EXPECT_EQ(r.status, 1) << path;
    EXPECT_EQ(r.err.rfind("pano4d: error: " + path + problem, 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

TEST(Pano4dBinaryTest, VersionAndUsage) {
  testing::TempDir dir;
  EXPECT_EQ(RunBinary("--version", dir).status, 0);
  EXPECT_EQ(RunBinary("bench budget --no-such-flag", dir).status, 64);
}

}  // namespace
}  // namespace pano4d
