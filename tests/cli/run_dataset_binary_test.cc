// `pano4d run --dataset` on a dataset without depth, as a user runs it:
// COLMAP triangulates points with the dataset's cameras at --factor, stereo
// on those cameras gives the depth (or --depth-dir maps, aligned to the
// points), and the validation frames are evaluated (label colmap; says
// COLMAP MISSING and skips without it).
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "colmap_ext/colmap_runner.h"
#include "src/core/json.h"
#include "tests/support/plan_json.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using testing::Slurp;

using testing::PlanStage;
using testing::RunPano4d;
const char* kShortFit =
    " --iterations 40 --expand-every 20 --validate-every 20";

// The tiny synthetic scene twice: as generated (depth/ included) and with
// depth/ deleted, the layout of a DyCheck capture without depth.
class RunDatasetTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    const fs::path log = dir_->path() / "synth.log";
    ASSERT_EQ(RunPano4d("synth --preset tiny --seed 5 --out '" +
                            (dir_->path() / "tiny").string() + "'",
                        log),
              0)
        << Slurp(log);
    fs::copy(dir_->path() / "tiny", dir_->path() / "no_depth",
             fs::copy_options::recursive);
    fs::remove_all(dir_->path() / "no_depth" / "depth");
  }
  static void TearDownTestSuite() { delete dir_; }
  void SetUp() override {
    if (!FindOnPath("colmap"))
      GTEST_SKIP() << "COLMAP MISSING: colmap is not on PATH";
  }
  static testing::TempDir* dir_;
};
testing::TempDir* RunDatasetTest::dir_ = nullptr;

TEST_F(RunDatasetTest, WithoutDepthItTriangulatesRunsStereoAndEvaluates) {
  const fs::path ws = dir_->path() / "ws_stereo";
  const fs::path log = dir_->path() / "stereo.log";
  const std::string run =
      "run --dataset '" + (dir_->path() / "no_depth").string() +
      "' --workspace '" + ws.string() + "' --eval" + kShortFit;
  ASSERT_EQ(RunPano4d(run, log), 0) << Slurp(log);

  // The plan names the source, and the stages did what it said.
  const nlohmann::json plan = ReadJson(ws / "pano4d/plan.json");
  EXPECT_EQ(plan["facts"]["depth_source"], "stereo");
  EXPECT_TRUE(PlanStage(plan, "sfm")["run"].get<bool>());
  EXPECT_NE(PlanStage(plan, "sfm")["why"].get<std::string>().find(
                "point_triangulator"),
            std::string::npos);
  EXPECT_NE(PlanStage(plan, "depth")["why"].get<std::string>().find("stereo"),
            std::string::npos);
  const nlohmann::json frames = ReadJson(ws / "pano4d/frames.json");
  EXPECT_EQ(frames["depth_source"], "stereo");
  EXPECT_TRUE(fs::exists(ws / "pano4d/depth/stereo.json"));
  // SfM worked at the evaluation factor (2x: 64x48), not the full size.
  const cv::Mat image = cv::imread((ws / "images/0_00000.png").string());
  EXPECT_EQ(image.cols, 64);
  EXPECT_EQ(image.rows, 48);
  // m* and u* on the dataset's covisibility masks.
  const nlohmann::json metrics = ReadJson(ws / "pano4d/metrics/metrics.json");
  EXPECT_TRUE(metrics["mean"]["mpsnr"].is_number()) << metrics.dump(2);
  EXPECT_TRUE(metrics["mean"]["upsnr"].is_number()) << metrics.dump(2);
  EXPECT_EQ(metrics["factor"], 2);

  // Again: sfm's steps, depth and fit are complete.
  ASSERT_EQ(RunPano4d(run, log), 0) << Slurp(log);
  const nlohmann::json again = ReadJson(ws / "pano4d/plan.json");
  EXPECT_EQ(again["results"]["depth"]["status"],
            "complete from an earlier run");
  EXPECT_EQ(again["results"]["fit"]["status"], "complete from an earlier run");
}

TEST_F(RunDatasetTest, DepthDirIsCheckedBeforeWorkThenAlignedToThePoints) {
  // Another tool's maps: here the generator's own, one per training frame.
  const fs::path maps = dir_->path() / "maps";
  fs::copy(dir_->path() / "tiny/depth/2x", maps, fs::copy_options::recursive);
  fs::rename(maps / "0_00003.npy", dir_->path() / "0_00003.npy");
  const fs::path ws = dir_->path() / "ws_external";
  const fs::path log = dir_->path() / "external.log";
  const std::string run = "run --dataset '" +
                          (dir_->path() / "no_depth").string() +
                          "' --workspace '" + ws.string() + "' --depth-dir '" +
                          maps.string() + "' --eval" + kShortFit;
  // A map missing: refused after the plan, before any stage ran.
  EXPECT_EQ(RunPano4d(run, log), 1) << Slurp(log);
  const std::string err = Slurp(log);
  EXPECT_NE(err.find("0_00003"), std::string::npos) << err;
  EXPECT_NE(err.find(maps.string()), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(ws / "database.db"));

  fs::rename(dir_->path() / "0_00003.npy", maps / "0_00003.npy");
  ASSERT_EQ(RunPano4d(run, log), 0) << Slurp(log);
  const nlohmann::json plan = ReadJson(ws / "pano4d/plan.json");
  EXPECT_EQ(plan["facts"]["depth_source"], "external");
  EXPECT_NE(
      PlanStage(plan, "depth")["why"].get<std::string>().find(maps.string()),
      std::string::npos);
  EXPECT_EQ(ReadJson(ws / "pano4d/frames.json")["depth_source"], "external");
  const nlohmann::json alignment = ReadJson(ws / "pano4d/depth/alignment.json");
  EXPECT_FALSE(alignment.empty());
}

TEST_F(RunDatasetTest, ASceneWithDepthKeepsItsDepth) {
  const fs::path ws = dir_->path() / "ws_given";
  const fs::path log = dir_->path() / "given.log";
  ASSERT_EQ(
      RunPano4d("run --dataset '" + (dir_->path() / "tiny").string() +
                    "' --workspace '" + ws.string() + "' --eval" + kShortFit,
                log),
      0)
      << Slurp(log);
  const nlohmann::json plan = ReadJson(ws / "pano4d/plan.json");
  EXPECT_EQ(plan["facts"]["depth_source"], "dataset");
  EXPECT_FALSE(PlanStage(plan, "sfm")["run"].get<bool>());
  EXPECT_FALSE(fs::exists(ws / "database.db"));
  EXPECT_EQ(ReadJson(ws / "pano4d/frames.json")["depth_source"], "dataset");
}

}  // namespace
}  // namespace pano4d
