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

// Errors that say what is wrong with the input as it is: a folder given
// to inspect, a folder that exists but is not a scene.
TEST(Pano4dBinaryTest, FoldersThatAreNotWhatWasAskedForAreNamedAsSuch) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir / "root" / "notascene");
  testing::WriteText(dir / "root" / "notascene" / "readme.txt", "hello");
  const Result inspect =
      RunBinary("inspect '" + dir.path().string() + "'", dir);
  EXPECT_EQ(inspect.status, 1);
  EXPECT_NE(inspect.err.find("is a folder"), std::string::npos) << inspect.err;
  const Result bench = RunBinary(
      "bench datasets --root '" + (dir / "root").string() +
          "' --scenes notascene --workspace '" + (dir / "ws").string() + "'",
      dir);
  EXPECT_EQ(bench.status, 1);
  EXPECT_NE(bench.err.find("notascene"), std::string::npos) << bench.err;
  EXPECT_NE(bench.err.find("is not a scene in a layout pano4d reads"),
            std::string::npos)
      << bench.err;
}

// Options outside their range are usage errors (64) that name the option
// and a readable range (not 300 digits), NaN and Inf included; limits that
// would exhaust memory are refused before any work.
TEST(Pano4dBinaryTest, OptionsOutsideTheirRangeReadWell) {
  testing::TempDir dir;
  const std::string ws = " --workspace '" + dir.path().string() + "'";
  const std::vector<std::pair<std::string, std::string>> usage = {
      {"render" + ws + " --degrees nan", "must be a number from 0 to 720"},
      {"render" + ws + " --time -1", "must be a number >= 0, not -1"},
      {"render" + ws + " --frames 2147483647",
       "must be a number from 1 to 108000"},
      {"render" + ws + " --fps 0", "must be a number from 1 to 240"},
      {"fit" + ws + " --flow-weight abc", "must be a number >= 0, not abc"},
      {"fit" + ws + " --hidden-thickness inf", "must be a finite number"},
      {"fit" + ws + " --resume --force", "excludes"},
      {"fit" + ws + " --seed 18446744073709551616",
       "a seed is a non-negative integer up to 18446744073709551615"},
      {"fit" + ws + " --seed -1", "a seed is a non-negative integer"},
      {"synth --out ''", "--out: must not be empty"},
      {"render" + ws + " --out ''", "--out: must not be empty"},
  };
  for (const auto& [args, message] : usage) {
    const Result r = RunBinary(args, dir);
    EXPECT_EQ(r.status, 64) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << args << "\n" << r.err;
    EXPECT_LT(r.err.size(), 400u) << r.err;
  }
  for (const auto& [args, field] :
       std::vector<std::pair<std::string, std::string>>{
           {"fit" + ws + " --dynamic-layers 1000000", "dynamic_layers"},
           {"fit" + ws + " --directions 100000", "directions"},
           {"fit" + ws + " --depth-weight 1e300", "depth_weight"}}) {
    const Result r = RunBinary(args, dir);
    EXPECT_EQ(r.status, 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(field), std::string::npos) << r.err;
  }
  const Result threads = RunBinary("--threads 100000 render" + ws, dir);
  EXPECT_NE(threads.err.find("more than this machine's"), std::string::npos)
      << threads.err;
}

}  // namespace
}  // namespace pano4d
