// The real lady-running capture through `pano4d run` (sfm, plane-sweep
// depth, fit and expansion; the only SfM of a real video in the suite),
// every 8th frame held out (labels real-data and
// colmap; says REAL DATA MISSING or COLMAP MISSING and skips when its input is
// absent).
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "colmap_ext/colmap_runner.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using testing::Slurp;

using testing::RunPano4d;

// 'path', for a shell (built with +=: GCC 12 warns falsely on
// "literal" + std::string&&).
std::string Quote(const fs::path& path) {
  std::string q = "'";
  q += path.string();
  q += "'";
  return q;
}

// The real capture and COLMAP, or a loud skip.
class FitRealDataTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!FindOnPath("colmap"))
      GTEST_SKIP() << "COLMAP MISSING: colmap is not on PATH";
    if (!fs::exists(video))
      GTEST_SKIP() << "REAL DATA MISSING: " << video
                   << " (set PANO4D_DATA_DIR to the folder of real captures)";
  }
  const fs::path video =
      fs::path(PANO4D_DATA_DIR) / "real" / "lady-running.mp4";
};

// `pano4d run` on the real capture, every 8th frame held out: the plan
// (SfM, plane-sweep depth, motion, fit and expansion run; eval is left out,
// since a video has no DyCheck ground truth), renders of the expanded views
// in the report, and the held-out PSNR. One run covers the fit issue's
// "through sfm, depth and fit" too: a second pipeline on the same video
// would double the slowest test of the suite (CI has 2 cores).
TEST_F(FitRealDataTest, LadyRunningThroughRunWithPlanAndExpandedViews) {
  testing::TempDir dir;
  const fs::path ws = dir / "ws";
  ASSERT_EQ(
      RunPano4d("run --video " + Quote(video) + " --workspace " + Quote(ws) +
                    " --max-size 480 --holdout 8 --iterations 600 "
                    "--expand-every 300 --validate-every 300",
                dir / "run.log"),
      0)
      << Slurp(dir / "run.log");
  const std::string log = Slurp(dir / "run.log");
  EXPECT_NE(log.find("pano4d plan (video"), std::string::npos) << log;
  const nlohmann::json plan =
      nlohmann::json::parse(Slurp(ws / "pano4d/plan.json"));
  for (const auto& s : plan.at("stages")) {
    if (s.at("stage") == "eval") {
      EXPECT_FALSE(s.at("run").get<bool>());
    } else {
      EXPECT_TRUE(s.at("run").get<bool>()) << s.dump();
    }
  }
  EXPECT_TRUE(fs::exists(ws / "report/expanded_sheet.png"));
  EXPECT_TRUE(fs::exists(ws / "report/index.md"));
  // The in-the-wild SfM: a handheld video of a running person.
  const nlohmann::json sfm =
      nlohmann::json::parse(Slurp(ws / "pano4d/sfm.json"));
  std::printf(
      "lady-running sfm: %d of %d frames registered, %d points, mean "
      "reprojection error %.3f px, %.1f%% of pixels masked as dynamic\n",
      sfm.at("registered").get<int>(), sfm.at("frames").get<int>(),
      sfm.at("points3D").get<int>(),
      sfm.at("mean_reprojection_error_px").get<double>(),
      100 * sfm.at("mean_dynamic_fraction").get<double>());
  EXPECT_GT(sfm.at("frames").get<int>(), 50);
  EXPECT_GE(sfm.at("posed_fraction").get<double>(), 0.9) << sfm.dump();
  EXPECT_LT(sfm.at("mean_reprojection_error_px").get<double>(), 2.0);
  const nlohmann::json frames =
      nlohmann::json::parse(Slurp(ws / "pano4d/frames.json"));
  const nlohmann::json fit =
      nlohmann::json::parse(Slurp(ws / "pano4d/fit.json"));
  const std::size_t held_out = frames.at("val").size();
  const double train_psnr = fit.at("train_psnr").get<double>();
  const double val_psnr = fit.at("metrics").at("psnr").get<double>();
  std::printf(
      "lady-running via run: %zu training and %zu held-out frames; %d static "
      "and %d dynamic Gaussians; training PSNR %.2f dB, held-out PSNR %.2f "
      "dB, %.0f s of fitting\n",
      frames.at("train").size(), held_out,
      fit.at("static_gaussians").get<int>(),
      fit.at("dynamic_gaussians").get<int>(), train_psnr, val_psnr,
      fit.at("seconds").at("total").get<double>());
  // 65 frames: 0, 8, ..., 64 held out.
  EXPECT_EQ(held_out, 9u);
  // Stereo depth keeps the estimated-depth weight of the depth loss, and
  // the expansion warps with rendered depth.
  EXPECT_EQ(frames.at("depth_source").get<std::string>(), "stereo");
  EXPECT_NE(fit.dump().find("\"depth_weight\":1.0"), std::string::npos);
  EXPECT_GT(fit.at("dynamic_gaussians").get<int>(), 0);
  EXPECT_FALSE(fit.at("expansion").at("steps").empty());
  EXPECT_EQ(fit["expansion"].at("options").at("warp_depth"), "rendered");
  // Measured (2 cores, 600 iterations, an expansion at 300: 666 s, the
  // longest test of the suite): training 20.84 dB, held out 19.99; at 1000
  // iterations (922 s) 21.69 and 20.63. The floors leave a margin for
  // thread scheduling and compilers; a broken stage falls far below them.
  EXPECT_GT(train_psnr, 19.5);
  EXPECT_GT(val_psnr, 18.0);
  EXPECT_LT(val_psnr, train_psnr);
}

}  // namespace
}  // namespace pano4d
