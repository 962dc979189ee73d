#include "src/cli/app.h"

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <set>

#include <gtest/gtest.h>

#include "src/core/camera.h"
#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/version.h"
#include "src/datasets/dycheck_dataset.h"
#include "tests/support/test_files.h"

namespace pano4d::cli {
namespace {

struct Result {
  int status;
  std::string out;
  std::string err;
};

Result RunCli(std::vector<std::string> args) {
  args.insert(args.begin(), "pano4d");
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  const int status = Main(static_cast<int>(argv.size()), argv.data());
  std::cout.flush();
  std::cerr.flush();
  Result r{status, ::testing::internal::GetCapturedStdout(),
           ::testing::internal::GetCapturedStderr()};
  return r;
}

int Lines(const std::string& s) {
  return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
}

TEST(CliTest, VersionAndHelp) {
  const Result version = RunCli({"--version"});
  EXPECT_EQ(version.status, kExitOk);
  EXPECT_EQ(version.out, std::string("pano4d ") + kVersion + "\n");
  const Result help = RunCli({"--help"});
  EXPECT_EQ(help.status, kExitOk);
  for (const char* name :
       {"sfm", "depth", "fit", "expand", "render", "export", "eval", "synth",
        "dataset", "run", "demo", "bench", "make-pairs", "inspect"}) {
    EXPECT_NE(help.out.find(name), std::string::npos) << name;
  }
  const Result bare = RunCli({});
  EXPECT_EQ(bare.status, kExitUsage);
}

TEST(CliTest, UsageErrorsExitSixtyFour) {
  EXPECT_EQ(RunCli({"--no-such-flag"}).status, kExitUsage);
  EXPECT_EQ(RunCli({"inspect"}).status, kExitUsage);  // missing path
  EXPECT_EQ(RunCli({"bench"}).status, kExitUsage);    // missing bench name
  EXPECT_EQ(RunCli({"--log-level", "loud", "inspect", "x.png"}).status,
            kExitUsage);
}

// In-process (the Python module's way in): the same parser and checks,
// errors thrown instead of printed, help as the binary prints it.
TEST(CliTest, CallCommandThrowsWhatMainPrints) {
  try {
    CallCommand({"fit", "--workspace", ".", "--no-such-flag"});
    FAIL() << "a usage error must throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), "pano4d fit");
    EXPECT_NE(std::string(e.what()).find("--no-such-flag"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(CallCommand({}), Error);
  const std::filesystem::path missing = "/nonexistent/pano4d/ws";
  EXPECT_THROW(CallCommand({"fit", "--workspace", missing.string()}), Error);
  const Result binary = RunCli({"fit", "--help"});
  EXPECT_EQ(binary.out, CommandHelp("fit"));
  EXPECT_THROW(CommandHelp("no-such-command"), std::exception);
}

TEST(CliTest, ANegativeSeedIsAUsageErrorNotAWrappedOne) {
  // Unsigned parsing would take -1 as 18446744073709551615.
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"fit", "--workspace", PANO4D_SOURCE_DIR,
                                 "--seed", "-1"},
        std::vector<std::string>{"synth", "--out", "never_written", "--seed",
                                 "-1"},
        std::vector<std::string>{"make-pairs", "--workspace", PANO4D_SOURCE_DIR,
                                 "--out", "never_written", "--seed", "-3"}}) {
    const Result r = RunCli(args);
    EXPECT_EQ(r.status, kExitUsage) << args[0];
    EXPECT_NE(r.err.find("non-negative"), std::string::npos)
        << args[0] << ": " << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists("never_written"));
  // A non-negative seed passes the check (the command then fails on an
  // empty folder, which is no workspace: not a usage error). Not the
  // source folder: a command that runs takes its workspace's lock there.
  testing::TempDir empty;
  EXPECT_EQ(RunCli({"fit", "--workspace", empty.path().string(), "--seed", "7"})
                .status,
            kExitError);
}

// --threads, before or after the subcommand, sets the threads the parallel
// loops use (bench reports them); a negative count is a usage error.
TEST(CliTest, ThreadsSetsTheParallelLoopsThreads) {
  const std::vector<std::string> bench = {
      "bench", "render",  "--json", "--repeats", "1", "--gaussians",
      "100",   "--width", "32",     "--height",  "24"};
  for (const bool after : {false, true}) {
    std::vector<std::string> args = bench;
    args.insert(after ? args.end() : args.begin(), {"--threads", "1"});
    const Result r = RunCli(args);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("\"threads\":1"), std::string::npos) << r.out;
  }
  EXPECT_EQ(RunCli({"--threads", "-2", "bench", "render"}).status, kExitUsage);
  // Back to one thread per core for the tests that follow.
  std::vector<std::string> all = bench;
  all.insert(all.begin(),
             {"--threads", std::to_string(std::max(
                               1u, std::thread::hardware_concurrency()))});
  EXPECT_EQ(RunCli(all).status, 0);
}

TEST(CliTest, SfmRefusesBadOptionsBeforeRunningAnything) {
  // No input: one line naming the flags.
  Result r = RunCli({"sfm", "--workspace", "ws_never_created"});
  EXPECT_EQ(r.status, kExitError);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("--video/--images/--dataset"), std::string::npos)
      << r.err;
  // An unknown camera model names the flag and the value.
  r = RunCli({"sfm", "--images", PANO4D_SOURCE_DIR, "--workspace",
              "ws_never_created", "--camera-model", "FISHEYE_9000"});
  EXPECT_EQ(r.status, kExitError);
  EXPECT_NE(r.err.find("--camera-model"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("FISHEYE_9000"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists("ws_never_created"));
  // A matcher colmap does not have is a usage error.
  EXPECT_EQ(RunCli({"sfm", "--images", PANO4D_SOURCE_DIR, "--workspace", "w",
                    "--matcher", "vocab_tree"})
                .status,
            kExitUsage);
}

TEST(CliTest, InspectImageAndCamera) {
  testing::TempDir dir;
  WriteImage(dir / "a.png", Image(20, 10));
  const Result image = RunCli({"inspect", (dir / "a.png").string()});
  ASSERT_EQ(image.status, kExitOk) << image.err;
  const Json j = Json::parse(image.out);
  EXPECT_EQ(j["kind"], "image");
  EXPECT_EQ(j["width"], 20);
  EXPECT_EQ(j["height"], 10);

  const Camera camera{
      CameraModelId::kOpenCV, 640, 480, {800, 800, 320, 240, -0.4, 0, 0, 0}};
  WriteJson(dir / "cam.json", CameraToJson(camera));
  const Result cam = RunCli({"inspect", (dir / "cam.json").string()});
  ASSERT_EQ(cam.status, kExitOk) << cam.err;
  const Json c = Json::parse(cam.out);
  EXPECT_EQ(c["model"], "OPENCV");
  EXPECT_EQ(c["round_trip"]["failures"], 0);
  EXPECT_LT(c["round_trip"]["max_error_px"].get<double>(), 1e-9);
}

TEST(CliTest, CorruptInputsGiveOneLineNamingTheFile) {
  testing::TempDir dir;
  testing::WriteTruncatedPng(dir / "cut.png");
  testing::WriteText(
      dir / "cam.json",
      R"({"model": "PINHOLE", "width": "640", "height": 480, "params": [1, 1, 1, 1]})");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {(dir / "cut.png").string(), "truncated PNG"},
      {(dir / "cam.json").string(),
       "field 'width' = \"640\": expected an integer"},
      {(dir / "missing.mp4").string(), "does not exist"},
  };
  for (const auto& [path, problem] : cases) {
    const Result r = RunCli({"inspect", path});
    EXPECT_EQ(r.status, kExitError) << path;
    EXPECT_EQ(Lines(r.err), 1) << r.err;
    EXPECT_EQ(r.err.rfind("pano4d: error: " + path + ": ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(problem), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty());
  }
}

TEST(CliTest, DatasetInfoDescribesADyCheckScene) {
  testing::TempDir dir;
  DyCheckScene scene;
  const PosedCamera camera{
      Camera{CameraModelId::kPinhole, 64, 48, {50, 50, 32, 24}}, Rigid3d()};
  for (int t = 0; t < 4; ++t) scene.train.push_back({0, t, camera});
  scene.val.push_back({1, 0, camera});
  WriteDyCheckMetadata(dir.path(), scene);
  const Result r =
      RunCli({"dataset", "info", dir.path().string(), "--factor", "1"});
  ASSERT_EQ(r.status, kExitOk) << r.err;
  const Json info = Json::parse(r.out);
  EXPECT_EQ(info["kind"], "dycheck");
  EXPECT_EQ(info["train"]["frames"], 4);
  EXPECT_EQ(info["val"]["frames_per_camera"]["1"], 1);
  EXPECT_EQ(info["train"]["image_sizes"]["64x48"], 4);

  const Result bad = RunCli({"dataset", "info", (dir / "nope").string()});
  EXPECT_EQ(bad.status, kExitError);
  EXPECT_EQ(Lines(bad.err), 1);
}

TEST(CliTest, BenchCameraReportsExactRoundTripsForEveryModel) {
  const Result r = RunCli(
      {"bench", "camera", "--grid", "16", "--min-seconds", "0.001", "--json"});
  ASSERT_EQ(r.status, kExitOk) << r.err;
  std::istringstream lines(r.out);
  std::string line;
  std::set<std::string> models;
  while (std::getline(lines, line)) {
    const Json row = Json::parse(line);
    models.insert(row["model"].get<std::string>());
    EXPECT_EQ(row["failures"], 0) << line;
    EXPECT_LT(row["max_error_px"].get<double>(), 1e-9) << line;
    EXPECT_GT(row["unproject_ns"].get<double>(), 0.0);
  }
  EXPECT_EQ(models.size(), AllCameraModels().size());
}

}  // namespace
}  // namespace pano4d::cli
