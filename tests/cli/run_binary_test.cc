// `pano4d run` as a user runs it on the tiny synthetic scene: the plan it
// prints and writes, the stages it leaves out (and why), resuming, and
// its errors.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/core/json.h"
#include "src/gs/scene4d.h"
#include "src/render/ply.h"
#include "tests/support/plan_json.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using testing::Slurp;

using testing::PlanStage;
using testing::RunPano4d;

class RunBinaryTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    for (const char* variant : {"", " --static"}) {
      const std::string name = *variant ? "tiny_static" : "tiny";
      ASSERT_EQ(
          RunPano4d("synth --preset tiny --seed 5" + std::string(variant) +
                        " --out '" + (dir_->path() / name).string() + "'",
                    dir_->path() / "synth.log"),
          0)
          << Slurp(dir_->path() / "synth.log");
    }
  }
  static void TearDownTestSuite() { delete dir_; }
  static testing::TempDir* dir_;
};
testing::TempDir* RunBinaryTest::dir_ = nullptr;

const char* kShortFit =
    " --iterations 40 --expand-every 20 --validate-every 20";

TEST_F(RunBinaryTest, PlansRunsAndResumesADataset) {
  const fs::path ws = dir_->path() / "ws";
  const fs::path log = dir_->path() / "run.log";
  ASSERT_EQ(
      RunPano4d("run --dataset '" + (dir_->path() / "tiny").string() +
                    "' --workspace '" + ws.string() + "' --eval" + kShortFit,
                log),
      0)
      << Slurp(log);
  const std::string out = Slurp(log);
  EXPECT_NE(out.find("pano4d plan (dataset"), std::string::npos) << out;
  EXPECT_NE(out.find("sfm        left out  poses given"), std::string::npos)
      << out;

  const nlohmann::json plan = ReadJson(ws / "pano4d/plan.json");
  EXPECT_FALSE(PlanStage(plan, "sfm")["run"].get<bool>());
  EXPECT_FALSE(PlanStage(plan, "depth")["run"].get<bool>());
  EXPECT_TRUE(PlanStage(plan, "motion")["run"].get<bool>());
  EXPECT_FALSE(PlanStage(plan, "motion")["pending"].get<bool>());
  EXPECT_TRUE(PlanStage(plan, "expansion")["run"].get<bool>());
  EXPECT_TRUE(PlanStage(plan, "eval")["run"].get<bool>());
  EXPECT_GT(plan["facts"]["dynamic_fraction"].get<double>(), 0.0);
  EXPECT_GT(plan["facts"]["unseen_fraction"].get<double>(), 0.0);
  EXPECT_EQ(plan["results"]["fit"]["status"], "done");
  EXPECT_EQ(plan["results"]["eval"]["status"], "done");

  const nlohmann::json fit = ReadJson(ws / "pano4d/fit.json");
  EXPECT_EQ(fit["iterations"], 40);
  EXPECT_GT(fit["motion_bases"].get<int>(), 0);
  EXPECT_FALSE(fit["expansion"]["steps"].empty());
  const nlohmann::json metrics = ReadJson(ws / "pano4d/metrics/metrics.json");
  EXPECT_TRUE(metrics["mean"]["mpsnr"].is_number()) << metrics.dump(2);

  // Again: nothing is redone.
  ASSERT_EQ(
      RunPano4d("run --dataset '" + (dir_->path() / "tiny").string() +
                    "' --workspace '" + ws.string() + "' --eval" + kShortFit,
                log),
      0)
      << Slurp(log);
  const nlohmann::json again = ReadJson(ws / "pano4d/plan.json");
  EXPECT_EQ(again["results"]["depth"]["status"],
            "complete from an earlier run");
  EXPECT_EQ(again["results"]["fit"]["status"], "complete from an earlier run");

  // Other fit options: fitted again from the start, not reused.
  ASSERT_EQ(RunPano4d("run --dataset '" + (dir_->path() / "tiny").string() +
                          "' --workspace '" + ws.string() + "' --no-expansion" +
                          kShortFit,
                      log),
            0)
      << Slurp(log);
  EXPECT_EQ(ReadJson(ws / "pano4d/plan.json")["results"]["fit"]["status"],
            "done");
  EXPECT_TRUE(ReadJson(ws / "pano4d/fit.json")["expansion"].is_null());
  EXPECT_FALSE(fs::exists(ws / "pano4d/expansion"));
}

// A dataset file edited after a run: the depth stage runs again, saying
// which file changed, and the fit starts again on the new frames. A corrupt
// depth map stops the run naming it; once it is fixed the same command
// completes.
TEST_F(RunBinaryTest, AChangedInputRunsItsStagesAgainAndAFixedOneCompletes) {
  const fs::path data = dir_->path() / "tiny_edited";
  fs::copy(dir_->path() / "tiny", data, fs::copy_options::recursive);
  const fs::path ws = dir_->path() / "ws_edited";
  const fs::path log = dir_->path() / "run_edited.log";
  const std::string run = "run --dataset '" + data.string() +
                          "' --workspace '" + ws.string() +
                          "' --iterations 10 --no-expansion";
  ASSERT_EQ(RunPano4d(run, log), 0) << Slurp(log);

  // Another training image in place of frame 3.
  fs::copy_file(data / "rgb/2x/0_00002.png", data / "rgb/2x/0_00003.png",
                fs::copy_options::overwrite_existing);
  fs::last_write_time(data / "rgb/2x/0_00003.png",
                      fs::last_write_time(data / "rgb/2x/0_00003.png") +
                          std::chrono::seconds(5));
  ASSERT_EQ(RunPano4d(run, log), 0) << Slurp(log);
  nlohmann::json results = ReadJson(ws / "pano4d/plan.json")["results"];
  EXPECT_EQ(results["depth"]["status"], "listed") << results.dump(2);
  EXPECT_NE(results["depth"]["why"].get<std::string>().find(
                "rgb/2x/0_00003.png changed"),
            std::string::npos)
      << results.dump(2);
  EXPECT_EQ(results["fit"]["status"], "done");
  EXPECT_EQ(results["fit"]["why"], "the training frames changed");
  EXPECT_NE(Slurp(log).find("depth runs: "), std::string::npos);

  // A truncated depth map: the run stops naming it.
  const fs::path depth = data / "depth/2x/0_00001.npy";
  const std::string good = Slurp(depth);
  {
    std::ofstream out(depth, std::ios::binary | std::ios::trunc);
    out << good.substr(0, good.size() / 2);
  }
  EXPECT_EQ(RunPano4d(run, log), 1);
  EXPECT_NE(Slurp(log).find("0_00001.npy"), std::string::npos) << Slurp(log);
  {
    std::ofstream out(depth, std::ios::binary | std::ios::trunc);
    out << good;
  }
  // Fixed with the same bytes: depth lists the frames again (the file's
  // time changed), and the fit, whose frames hash as before, is reused.
  ASSERT_EQ(RunPano4d(run, log), 0) << Slurp(log);
  results = ReadJson(ws / "pano4d/plan.json")["results"];
  EXPECT_EQ(results["depth"]["status"], "listed");
  EXPECT_EQ(results["fit"]["status"], "complete from an earlier run");
  EXPECT_NE(Slurp(log).find("fit reused: nothing it read changed"),
            std::string::npos)
      << Slurp(log);

  // Unchanged: both reused, and the log says so.
  ASSERT_EQ(RunPano4d(run, log), 0) << Slurp(log);
  results = ReadJson(ws / "pano4d/plan.json")["results"];
  EXPECT_EQ(results["depth"]["status"], "complete from an earlier run");
  EXPECT_EQ(results["depth"]["why"], "nothing it read changed");
  EXPECT_EQ(results["fit"]["status"], "complete from an earlier run");

  // Frames changed and listed again by `pano4d depth` by hand: run reuses
  // that depth stage, but not the fit made on the old frames.
  fs::copy_file(data / "rgb/2x/0_00004.png", data / "rgb/2x/0_00005.png",
                fs::copy_options::overwrite_existing);
  ASSERT_EQ(RunPano4d("depth --workspace '" + ws.string() + "' --dataset '" +
                          data.string() + "'",
                      log),
            0)
      << Slurp(log);
  ASSERT_EQ(RunPano4d(run, log), 0) << Slurp(log);
  results = ReadJson(ws / "pano4d/plan.json")["results"];
  EXPECT_EQ(results["depth"]["status"], "complete from an earlier run");
  EXPECT_EQ(results["fit"]["status"], "done");
  EXPECT_EQ(results["fit"]["why"], "the training frames changed");
}

TEST_F(RunBinaryTest, AStaticSceneGetsNoMotionAndNoEvalUnlessAsked) {
  const fs::path ws = dir_->path() / "ws_static";
  const fs::path log = dir_->path() / "run_static.log";
  ASSERT_EQ(
      RunPano4d("run --dataset '" + (dir_->path() / "tiny_static").string() +
                    "' --workspace '" + ws.string() + "' --no-expansion" +
                    kShortFit,
                log),
      0)
      << Slurp(log);
  const nlohmann::json plan = ReadJson(ws / "pano4d/plan.json");
  EXPECT_FALSE(PlanStage(plan, "motion")["run"].get<bool>());
  EXPECT_NE(PlanStage(plan, "motion")["why"].get<std::string>().find(
                "no dynamic content"),
            std::string::npos);
  EXPECT_NE(PlanStage(plan, "expansion")["why"].get<std::string>().find(
                "--no-expansion"),
            std::string::npos);
  EXPECT_FALSE(PlanStage(plan, "eval")["run"].get<bool>());
  EXPECT_FALSE(plan["results"].contains("eval"));
  const nlohmann::json fit = ReadJson(ws / "pano4d/fit.json");
  EXPECT_EQ(fit["motion_bases"], 0);
  EXPECT_EQ(fit["dynamic_gaussians"], 0);
  EXPECT_TRUE(fit["expansion"].is_null());
}

TEST_F(RunBinaryTest, BadInputsAreRefusedWithTheReason) {
  const fs::path log = dir_->path() / "run_bad.log";
  const std::string tiny = (dir_->path() / "tiny").string();
  // Two inputs: a usage error.
  EXPECT_EQ(
      RunPano4d("run --dataset '" + tiny + "' --images '" + tiny +
                    "' --workspace '" + (dir_->path() / "x").string() + "'",
                log),
      64)
      << Slurp(log);
  // No workspace.
  EXPECT_EQ(RunPano4d("run --dataset '" + tiny + "'", log), 1) << Slurp(log);
  EXPECT_NE(Slurp(log).find("--workspace"), std::string::npos) << Slurp(log);
  // A folder that is no COLMAP workspace: named, with what was looked for.
  const fs::path empty = dir_->path() / "not_colmap";
  fs::create_directories(empty);
  EXPECT_EQ(RunPano4d("run --colmap '" + empty.string() + "'", log), 1);
  const std::string err = Slurp(log);
  EXPECT_NE(err.find(empty.string()), std::string::npos) << err;
  EXPECT_NE(err.find("sparse/0"), std::string::npos) << err;
}

// The README's first command, on the tiny scene: the report opens with
// numbers and pictures, and `pano4d eval` on the saved renders gives the
// report's numbers again.
TEST_F(RunBinaryTest, DemoWritesAReportThatEvalReproduces) {
  const fs::path ws = dir_->path() / "demo";
  const fs::path log = dir_->path() / "demo.log";
  ASSERT_EQ(RunPano4d("demo --preset tiny --iterations 40 --workspace '" +
                          ws.string() + "'",
                      log),
            0)
      << Slurp(log);
  const fs::path report = ws / "report";
  const std::string index = Slurp(report / "index.md");
  for (const char* part :
       {"## Stages", "## Metrics", "| pano4d |",
        "PanoGaussian (Ours) (paper, mean)", "![fit](fit.png)",
        "![validation](val_sheet.png)", "![expanded](expanded_sheet.png)",
        "panorama_static.png"}) {
    EXPECT_NE(index.find(part), std::string::npos) << part << "\n" << index;
  }
  for (const char* file :
       {"fit.png", "val_sheet.png", "expanded_sheet.png", "panorama_static.png",
        "metrics.json", "plan.json"}) {
    EXPECT_GT(fs::file_size(report / file), 1000u) << file;
  }
  int ply = 0, mp4 = 0;
  for (const auto& e : fs::directory_iterator(report)) {
    ply += e.path().extension() == ".ply";
    mp4 += e.path().extension() == ".mp4";
  }
  EXPECT_EQ(ply, 1);  // scene_t<canonical time>.ply
  // MP4 needs OpenCV's FFmpeg backend; without it the report says so.
  if (mp4 == 0) {
    EXPECT_NE(index.find("## Not written"), std::string::npos) << index;
  } else {
    EXPECT_EQ(mp4, 2);
  }

  const fs::path again = dir_->path() / "demo_eval";
  ASSERT_EQ(
      RunPano4d("eval --dataset '" + (ws / "dataset").string() +
                    "' --renders '" + (ws / "pano4d/renders/val").string() +
                    "' --out '" + again.string() + "'",
                log),
      0)
      << Slurp(log);
  const nlohmann::json reported = ReadJson(report / "metrics.json");
  const nlohmann::json evaluated = ReadJson(again / "metrics.json");
  for (const char* key : {"psnr", "mpsnr", "upsnr", "ssim", "mssim", "ussim"}) {
    ASSERT_TRUE(reported["mean"][key].is_number()) << key;
    EXPECT_DOUBLE_EQ(reported["mean"][key].get<double>(),
                     evaluated["mean"][key].get<double>())
        << key;
  }
}

// render and export on a fitted workspace: frames, videos, camera files
// that round-trip, PLY per time step, the COLMAP model, and bad requests.
TEST_F(RunBinaryTest, RenderAndExportTheFittedScene) {
  const fs::path ws = dir_->path() / "ws_render";
  const fs::path log = dir_->path() / "render.log";
  ASSERT_EQ(RunPano4d("run --dataset '" + (dir_->path() / "tiny").string() +
                          "' --workspace '" + ws.string() + "'" + kShortFit,
                      log),
            0)
      << Slurp(log);
  const std::string w = " --workspace '" + ws.string() + "'";
  ASSERT_EQ(RunPano4d("render" + w + " --trajectory orbit --frames 8", log), 0)
      << Slurp(log);
  const fs::path orbit = ws / "pano4d/renders/orbit";
  for (int i = 0; i < 8; ++i) {
    char name[16];
    std::snprintf(name, sizeof(name), "%05d.png", i);
    EXPECT_TRUE(fs::exists(orbit / name)) << name;
  }
  const nlohmann::json cameras = ReadJson(orbit / "cameras.json");
  ASSERT_EQ(cameras["views"].size(), 8u);
  // The camera file renders the same frames again.
  ASSERT_EQ(RunPano4d("render" + w + " --trajectory '" +
                          (orbit / "cameras.json").string() + "' --out '" +
                          (dir_->path() / "again").string() + "'",
                      log),
            0)
      << Slurp(log);
  for (const char* f : {"00000.png", "00005.png"}) {
    EXPECT_EQ(Slurp(orbit / f), Slurp(dir_->path() / "again" / f)) << f;
  }
  // And writes the cameras as it read them, so that every later
  // generation renders the same frames too.
  EXPECT_EQ(ReadJson(dir_->path() / "again" / "cameras.json")["views"],
            cameras["views"]);
  // Bullet time: every view at the time asked for.
  ASSERT_EQ(
      RunPano4d("render" + w + " --trajectory bullet --frames 6 --time 2", log),
      0)
      << Slurp(log);
  for (const auto& v :
       ReadJson(ws / "pano4d/renders/bullet/cameras.json")["views"])
    EXPECT_EQ(v["t"], 2);
  // Bad requests name what is wrong.
  EXPECT_EQ(RunPano4d("render" + w + " --trajectory nowhere.json", log), 1);
  EXPECT_NE(Slurp(log).find("nowhere.json"), std::string::npos) << Slurp(log);
  EXPECT_EQ(RunPano4d("render" + w + " --trajectory bullet --time 999", log),
            1);
  EXPECT_NE(Slurp(log).find("--time"), std::string::npos) << Slurp(log);

  // What an earlier, longer export and a SIGTERM during one leave behind:
  // neither may stay beside the new files.
  fs::create_directories(ws / "pano4d/export/ply");
  testing::WriteText(ws / "pano4d/export/ply/t_00099.ply", "an earlier run's");
  testing::WriteText(ws / "pano4d/export/ply/t_00004.tmp.999999999.4.ply",
                     "a killed run's temporary");
  ASSERT_EQ(RunPano4d("export" + w, log), 0) << Slurp(log);
  EXPECT_FALSE(fs::exists(ws / "pano4d/export/ply/t_00099.ply"));
  EXPECT_FALSE(
      fs::exists(ws / "pano4d/export/ply/t_00004.tmp.999999999.4.ply"));
  EXPECT_FALSE(fs::exists(ws / "pano4d/export/INCOMPLETE"));
  const nlohmann::json frames = ReadJson(ws / "pano4d/frames.json");
  int plys = 0;
  for (const auto& e : fs::directory_iterator(ws / "pano4d/export/ply"))
    plys += e.path().extension() == ".ply";
  EXPECT_EQ(plys, frames["num_times"].get<int>());
  const std::string images = Slurp(ws / "pano4d/export/colmap/images.txt");
  EXPECT_NE(images.find("source/"), std::string::npos);
  EXPECT_NE(images.find("step_01/dir_0/"), std::string::npos);
  // The manifest lists every time's PLY in order; the compact form holds
  // the same scene: its static Gaussians are the first rows of every PLY,
  // in the same order, and its dynamic ones posed at a time are that
  // time's other rows.
  const fs::path exported = ws / "pano4d/export";
  const nlohmann::json manifest = ReadJson(exported / "ply/sequence.json");
  EXPECT_EQ(manifest["format"], "pano4d-ply-sequence");
  ASSERT_EQ(manifest["frames"].size(), frames["num_times"].get<std::size_t>());
  const GaussianScene scene = ReadScene4d(exported);
  EXPECT_EQ(manifest["static_gaussians"], scene.statics.size());
  GaussianModel posed;
  for (std::size_t t = 0; t < manifest["frames"].size(); ++t) {
    const nlohmann::json& f = manifest["frames"][t];
    EXPECT_EQ(f["time"], t);
    const GaussianModel ply =
        ReadPly(exported / "ply" / f["file"].get<std::string>());
    ASSERT_EQ(ply.size(), scene.size());
    scene.ComposeAt(static_cast<int>(t), &posed);
    for (std::size_t i = 0; i < scene.statics.size() * 3; ++i)
      ASSERT_EQ(ply.means[i], posed.means[i])
          << "time " << t << " row " << i / 3;
    for (std::size_t i = scene.statics.size() * 3; i < ply.means.size(); ++i)
      ASSERT_NEAR(ply.means[i], posed.means[i], 1e-2) << "time " << t;
  }
  EXPECT_NE(Slurp(log).find("compact 4D scene"), std::string::npos)
      << Slurp(log);

  // `view` writes the page, its libraries and the scene; here with a
  // stand-in for npm's libraries (the browser test runs the real ones).
  const fs::path libraries = dir_->path() / "viewer_sources";
  for (const char* f :
       {"index.html", "viewer.js",
        "node_modules/three/build/three.module.min.js",
        "node_modules/three/build/three.core.min.js",
        "node_modules/three/examples/jsm/controls/OrbitControls.js",
        "node_modules/three/examples/jsm/postprocessing/Pass.js",
        "node_modules/@sparkjsdev/spark/dist/spark.module.min.js",
        "node_modules/three/LICENSE",
        "node_modules/@sparkjsdev/spark/LICENSE"}) {
    fs::create_directories((libraries / f).parent_path());
    testing::WriteText(libraries / f, std::string("stand-in ") + f);
  }
  const fs::path view = dir_->path() / "view";
  const std::string with_sources = "PANO4D_VIEWER_DIR='" + libraries.string() +
                                   "' " + PANO4D_BINARY_DIR + "/pano4d view" +
                                   w + " --out '" + view.string() + "'";
  ASSERT_EQ(testing::RunLogged(with_sources, log), 0) << Slurp(log);
  for (const char* f : {"index.html", "viewer.js", "lib/spark.module.min.js",
                        "lib/addons/controls/OrbitControls.js",
                        "lib/LICENSE.spark.txt", "scene4d.json", "scene4d.bin"})
    EXPECT_TRUE(fs::exists(view / f)) << f;
  const nlohmann::json header = ReadJson(view / "scene4d.json");
  EXPECT_EQ(header["extras"]["cameras"]["training"].size(),
            frames["train"].size());
  EXPECT_NE(Slurp(log).find("a PLY per time"), std::string::npos) << Slurp(log);
  // On a disk that fills up: the disk named as full, the folder marked
  // incomplete.
  testing::SmallDisk disk(64);
  if (disk.mounted()) {
    const std::string to_disk = "PANO4D_VIEWER_DIR='" + libraries.string() +
                                "' " + PANO4D_BINARY_DIR + "/pano4d view" + w +
                                " --out '" + (disk / "view").string() + "'";
    EXPECT_EQ(testing::RunLogged(to_disk, log), 1);
    EXPECT_NE(Slurp(log).find("the disk holding it is full"), std::string::npos)
        << Slurp(log);
    EXPECT_TRUE(fs::exists(disk / "view" / "INCOMPLETE"));
  } else {
    std::cerr << "SMALL DISK UNAVAILABLE, view on a full disk not tested: "
              << disk.why() << "\n";
  }
  // Without npm's libraries: the file and the command that installs it.
  fs::remove(libraries /
             "node_modules/@sparkjsdev/spark/dist/spark.module.min.js");
  EXPECT_EQ(testing::RunLogged(with_sources, log), 1);
  EXPECT_NE(Slurp(log).find("spark.module.min.js"), std::string::npos)
      << Slurp(log);
  EXPECT_NE(Slurp(log).find("npm ci"), std::string::npos) << Slurp(log);
}

// The stiff and extreme suite: every case runs and counts values, none of
// them non-finite.
TEST_F(RunBinaryTest, StabilitySuiteFindsNoNonFiniteValue) {
  const fs::path log = dir_->path() / "stability.log";
  const fs::path out = dir_->path() / "stability.json";
  ASSERT_EQ(RunPano4d("bench stability --fit-iterations 30 --out '" +
                          out.string() + "'",
                      log),
            0)
      << Slurp(log);
  const nlohmann::json j = ReadJson(out);
  EXPECT_EQ(j["non_finite"], 0);
  ASSERT_EQ(j["cases"].size(), 8u) << j.dump(2);
  for (const auto& c : j["cases"]) {
    EXPECT_GT(c["values"].get<long long>(), 0) << c.dump();
    EXPECT_EQ(c["non_finite"], 0) << c.dump();
  }
  const std::string table = Slurp(log);
  for (const char* name :
       {"expansion angles up to 90 degrees", "panorama seam and poles",
        "degenerate covariances", "very near and very far geometry",
        "scaled by 1e-3", "scaled by 1e3", "static-camera video"}) {
    EXPECT_NE(table.find(name), std::string::npos) << name << "\n" << table;
  }
}

// Error against run time across budgets, on the tiny scene with two small
// budgets: a row per run, a CSV and plot per resolution; a second call
// reads the finished runs back.
TEST_F(RunBinaryTest, BudgetBenchTabulatesEveryRun) {
  const fs::path ws = dir_->path() / "budget";
  const fs::path log = dir_->path() / "budget.log";
  const std::string args =
      "bench budget --preset tiny --iterations 20,40 "
      "--factors 2 --workspace '" +
      ws.string() + "'";
  ASSERT_EQ(RunPano4d(args, log), 0) << Slurp(log);
  const std::string table = Slurp(ws / "budget.md");
  EXPECT_NE(table.find("| 2x | 20 |"), std::string::npos) << table;
  EXPECT_NE(table.find("| 2x | 40 |"), std::string::npos) << table;
  EXPECT_GT(fs::file_size(ws / "budget_2x.png"), 1000u);
  const std::string csv = Slurp(ws / "budget_2x.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3) << csv;
  const auto fitted = fs::last_write_time(ws / "f2_i40/pano4d/fit.json");
  ASSERT_EQ(RunPano4d(args, log), 0) << Slurp(log);
  EXPECT_EQ(fs::last_write_time(ws / "f2_i40/pano4d/fit.json"), fitted);
  EXPECT_EQ(Slurp(ws / "budget.md"), table);
}

}  // namespace
}  // namespace pano4d
