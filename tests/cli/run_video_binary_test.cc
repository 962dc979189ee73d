// `pano4d run --video` on a video that COLMAP can pose only in part: the
// run stops after sfm with the share posed and the cause, instead of
// fitting a fraction of the video (label colmap; says COLMAP MISSING and
// skips without it).
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/videoio.hpp>

#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/subprocess.h"
#include "src/datasets/dataset.h"
#include "tests/support/plan_json.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using testing::PlanStage;
using testing::RunPano4d;
using testing::Slurp;

// Textured frames the mapper poses, then as many uniformly grey frames,
// which have no keypoints at all.
constexpr int kTexturedFrames = 12;

class RunVideoTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!FindOnPath("colmap")) return;
    dir_ = new testing::TempDir();
    const fs::path log = dir_->path() / "synth.log";
    ASSERT_EQ(RunPano4d("synth --preset small --static --seed 0 --out '" +
                            (dir_->path() / "scene").string() + "'",
                        log),
              0)
        << Slurp(log);
    const Dataset scene = LoadDataset(dir_->path() / "scene", 1);
    ASSERT_GE(scene.train.size(), static_cast<std::size_t>(kTexturedFrames));
    const cv::Mat first = ReadImage(scene.train[0].rgb).ToBgr8();
    cv::VideoWriter writer((dir_->path() / "half.avi").string(),
                           cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0,
                           first.size());
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < kTexturedFrames; ++i)
      writer.write(ReadImage(scene.train[i].rgb).ToBgr8());
    for (int i = 0; i < kTexturedFrames; ++i)
      writer.write(cv::Mat(first.size(), CV_8UC3, cv::Scalar::all(128)));
  }
  static void TearDownTestSuite() { delete dir_; }
  void SetUp() override {
    if (!FindOnPath("colmap"))
      GTEST_SKIP() << "COLMAP MISSING: colmap is not on PATH; install it "
                      "with `apt-get install colmap` (scripts/setup.sh does)";
  }
  static testing::TempDir* dir_;
};
testing::TempDir* RunVideoTest::dir_ = nullptr;

TEST_F(RunVideoTest, TooFewFramesPosedStopsTheRunNamingShareAndCause) {
  const fs::path ws = dir_->path() / "ws";
  const fs::path log = dir_->path() / "run.log";
  const std::string run =
      "run --video '" + (dir_->path() / "half.avi").string() +
      "' --workspace '" + ws.string() + "' --iterations 20 --no-expansion";
  const int status = RunPano4d(run, log);
  const std::string out = Slurp(log);
  ASSERT_NE(status, 0) << out;
  const std::size_t error = out.find("error:");
  std::printf("the run's error: %s\n", error == std::string::npos
                                           ? "(none)"
                                           : out.substr(error).c_str());
  const nlohmann::json plan = ReadJson(ws / "pano4d/plan.json");
  const int posed = plan["facts"]["sfm_posed"].get<int>();
  EXPECT_EQ(plan["facts"]["sfm_frames"].get<int>(), 2 * kTexturedFrames);
  EXPECT_LE(posed, kTexturedFrames);
  EXPECT_GE(posed, 3) << "the textured half should be posed";
  // The plan said so before the run began, and the error says the share,
  // the cause and what to try.
  EXPECT_NE(
      PlanStage(plan, "sfm")["why"].get<std::string>().find("--min-posed"),
      std::string::npos);
  EXPECT_EQ(plan["results"]["sfm"]["status"], "too few frames posed");
  EXPECT_NE(out.find(std::to_string(posed) + " of " +
                     std::to_string(2 * kTexturedFrames) + " frames posed"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("too few features"), std::string::npos) << out;
  EXPECT_NE(out.find("--min-posed"), std::string::npos) << out;
  // Nothing after sfm ran.
  EXPECT_FALSE(fs::exists(ws / "pano4d/frames.json"));
  EXPECT_FALSE(fs::exists(ws / "pano4d/fit.json"));
  const nlohmann::json sfm = ReadJson(ws / "pano4d/sfm.json");
  EXPECT_EQ(sfm["diagnosis"]["cause"], "too few features");
  EXPECT_GE(sfm["diagnosis"]["unposed_causes"]["too few features"].get<int>(),
            kTexturedFrames);
}

// A pan: sfm poses it with the rotation-only model, the plan says so, and
// the run stops there with the reason (no points, no baseline).
TEST_F(RunVideoTest, APanIsPosedRotationOnlyAndTheRunSaysWhyItStops) {
  const fs::path log = dir_->path() / "pan_synth.log";
  ASSERT_EQ(RunPano4d("synth --preset small --seed 0 --trajectory pan --out '" +
                          (dir_->path() / "pan").string() + "'",
                      log),
            0)
      << Slurp(log);
  const Dataset scene = LoadDataset(dir_->path() / "pan", 1);
  const cv::Mat first = ReadImage(scene.train[0].rgb).ToBgr8();
  const fs::path video = dir_->path() / "pan.avi";
  {
    cv::VideoWriter writer(video.string(),
                           cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0,
                           first.size());
    ASSERT_TRUE(writer.isOpened());
    for (std::size_t i = 0; i < scene.train.size(); i += 2)
      writer.write(ReadImage(scene.train[i].rgb).ToBgr8());
  }
  const fs::path ws = dir_->path() / "ws_pan";
  const fs::path run_log = dir_->path() / "pan_run.log";
  ASSERT_NE(RunPano4d("run --video '" + video.string() + "' --workspace '" +
                          ws.string() + "' --iterations 20",
                      run_log),
            0)
      << Slurp(run_log);
  const std::string out = Slurp(run_log);
  EXPECT_NE(out.find("rotation-only"), std::string::npos) << out;
  const nlohmann::json plan = ReadJson(ws / "pano4d/plan.json");
  EXPECT_EQ(plan["facts"]["camera_motion"], "rotation-only");
  EXPECT_EQ(plan["facts"]["sfm_posed"], plan["facts"]["sfm_frames"]);
  EXPECT_NE(PlanStage(plan, "sfm")["why"].get<std::string>().find(
                "rotation-only camera model"),
            std::string::npos);
  EXPECT_EQ(plan["results"]["sfm"]["status"], "rotation-only");
  EXPECT_FALSE(fs::exists(ws / "pano4d/fit.json"));

  // With depth maps given (the scene's own, named as the video's frames)
  // the run goes on: the maps as they are, and a short fit.
  const fs::path depth_dir = dir_->path() / "pan_depth";
  EnsureDirectory(depth_dir);
  for (std::size_t i = 0; i < scene.train.size(); i += 2) {
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%06zu.npy", i / 2);
    fs::copy_file(
        dir_->path() / "pan" / "depth" / "1x" / (scene.train[i].id + ".npy"),
        depth_dir / name);
  }
  const fs::path depth_log = dir_->path() / "pan_depth_run.log";
  ASSERT_EQ(RunPano4d("run --video '" + video.string() + "' --workspace '" +
                          ws.string() + "' --depth-dir '" + depth_dir.string() +
                          "' --max-size 240 --iterations 20 --no-expansion",
                      depth_log),
            0)
      << Slurp(depth_log);
  const nlohmann::json done = ReadJson(ws / "pano4d/plan.json");
  EXPECT_NE(PlanStage(done, "depth")["why"].get<std::string>().find("as given"),
            std::string::npos);
  EXPECT_TRUE(fs::exists(ws / "pano4d/fit.json"));
}

}  // namespace
}  // namespace pano4d
