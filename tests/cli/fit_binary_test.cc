// `pano4d depth` and `pano4d fit` as a user runs them, on the tiny synthetic
// scene: outputs, metrics keys, errors, and kill -9 followed by --resume.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/core/file.h"
#include "tests/support/test_files.h"

extern char** environ;

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using testing::Slurp;

using testing::RunPano4d;

// The binary itself, for the kill -9 test that spawns it directly.
const std::string kBinary = std::string(PANO4D_BINARY_DIR) + "/pano4d";

class FitBinaryTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    const fs::path dataset = dir_->path() / "tiny";
    ASSERT_EQ(RunPano4d("synth --preset tiny --seed 3 --out '" +
                            dataset.string() + "'",
                        dir_->path() / "synth.log"),
              0)
        << Slurp(dir_->path() / "synth.log");
  }
  static void TearDownTestSuite() { delete dir_; }

  // A workspace with frames.json from the tiny dataset.
  static fs::path Workspace(const std::string& name) {
    const fs::path ws = dir_->path() / name;
    const fs::path log = dir_->path() / (name + "_depth.log");
    EXPECT_EQ(RunPano4d("depth --workspace '" + ws.string() + "' --dataset '" +
                            (dir_->path() / "tiny").string() + "'",
                        log),
              0)
        << Slurp(log);
    return ws;
  }

  static testing::TempDir* dir_;
};
testing::TempDir* FitBinaryTest::dir_ = nullptr;

// --converge-on with --iterations: the stop ends the fit as `converged`
// and says why; bad values are refused naming the flag.
TEST_F(FitBinaryTest, TheConvergenceStopEndsAFitAndSaysWhy) {
  const fs::path ws = Workspace("ws_converge");
  const fs::path log = ws / "fit.log";
  const std::string fit = "fit --workspace '" + ws.string() +
                          "' --iterations 100 --converge-on val "
                          "--converge-every 10 --converge-window 20 ";
  ASSERT_EQ(RunPano4d(fit + "--converge-min-gain 100", log), 0) << Slurp(log);
  const nlohmann::json summary =
      nlohmann::json::parse(Slurp(ws / "pano4d/fit.json"));
  // Densification ends at 50: samples at 60, 70, 80; 80 against 60.
  EXPECT_EQ(summary.at("iterations").get<int>(), 80);
  EXPECT_EQ(summary.at("termination"), "converged");
  EXPECT_NE(Slurp(log).find("fit: converged at iteration 80: val PSNR"),
            std::string::npos)
      << Slurp(log);
  EXPECT_EQ(RunPano4d("fit --workspace '" + ws.string() +
                          "' --force --converge-on sometimes",
                      log),
            64);
  EXPECT_EQ(RunPano4d("fit --workspace '" + ws.string() +
                          "' --force --converge-every 10 --converge-window 25",
                      log),
            1);
  EXPECT_NE(Slurp(log).find("--converge-window"), std::string::npos)
      << Slurp(log);
  // Refused before --force touched the fit.
  EXPECT_TRUE(fs::exists(ws / "pano4d/fit.json"));
  EXPECT_FALSE(fs::exists(ws / "pano4d/previous_fit"));
}

TEST_F(FitBinaryTest, WritesCheckpointRunLogRendersAndMetrics) {
  const fs::path ws = Workspace("ws_outputs");
  const fs::path log = ws / "fit.log";
  ASSERT_EQ(
      RunPano4d("fit --workspace '" + ws.string() +
                    "' --iterations 40 --validate-every 20 --log-every 10",
                log),
      0)
      << Slurp(log);
  EXPECT_TRUE(fs::exists(ws / "pano4d/checkpoints/fit.ckpt"));
  const nlohmann::json metrics =
      nlohmann::json::parse(Slurp(ws / "pano4d/metrics/metrics.json"));
  for (const char* key : {"psnr", "ssim", "mpsnr", "mssim", "upsnr", "ussim"}) {
    ASSERT_TRUE(metrics.at("mean").contains(key)) << key;
    EXPECT_TRUE(metrics["mean"][key].is_number()) << key;
  }
  const nlohmann::json fit =
      nlohmann::json::parse(Slurp(ws / "pano4d/fit.json"));
  EXPECT_EQ(fit.at("iterations").get<int>(), 40);
  // --iterations alone runs to its end: the convergence stop is off.
  EXPECT_EQ(fit.at("options_used").at("converge_on"), "off");
  EXPECT_TRUE(fit.at("convergence").is_null());
  // The dataset gives the depth, so the depth loss has its given-depth
  // weight (--depth-weight not passed).
  const nlohmann::json frames =
      nlohmann::json::parse(Slurp(ws / "pano4d/frames.json"));
  EXPECT_EQ(frames.at("depth_source").get<std::string>(), "dataset");
  EXPECT_EQ(fit.dump().find("\"depth_weight\":1.0"), std::string::npos);
  EXPECT_NE(fit.dump().find("\"depth_weight\":5.0"), std::string::npos)
      << fit.dump();
  EXPECT_NE(Slurp(log).find("depth weight 5 (depth from dataset)"),
            std::string::npos);
  EXPECT_GT(fit.at("dynamic_gaussians").get<int>(), 0);
  EXPECT_GT(fit.at("motion_bases").get<int>(), 0);
  // A row every 10 iterations, validation values at 20 and 40.
  const std::string csv = Slurp(ws / "pano4d/metrics/fit.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 5) << csv;
  EXPECT_TRUE(fs::exists(ws / "pano4d/metrics/fit.png"));
  int renders = 0;
  for (const auto& e : fs::directory_iterator(ws / "pano4d/renders/val"))
    renders += e.path().extension() == ".png";
  EXPECT_EQ(renders, 16);  // tiny: 8 frames x 2 validation cameras
  const std::string report = Slurp(log);
  EXPECT_NE(report.find("pano4d fit report"), std::string::npos);
  EXPECT_NE(report.find("validation"), std::string::npos);

  // The rasterizer's benchmark on the fitted scene.
  const fs::path bench = ws / "bench.json";
  ASSERT_EQ(RunPano4d("bench render --json --repeats 2 --checkpoint '" +
                          ws.string() + "'",
                      bench),
            0)
      << Slurp(bench);
  const nlohmann::json row = nlohmann::json::parse(Slurp(bench));
  EXPECT_EQ(row.at("gaussians").get<int>(),
            fit.at("static_gaussians").get<int>() +
                fit.at("dynamic_gaussians").get<int>());
  EXPECT_GT(row.at("forward_ms").get<double>(), 0.0);
  // The stages of a step, each timed: the forward's add up to it.
  double stages = 0;
  for (const char* key : {"project_ms", "bin_ms", "blend_ms"}) {
    ASSERT_TRUE(row.contains(key)) << key;
    EXPECT_GT(row[key].get<double>(), 0.0) << key;
    stages += row[key].get<double>();
  }
  EXPECT_LE(stages, 1.5 * row["forward_ms"].get<double>() + 0.1);
  for (const char* key : {"blend_backward_ms", "project_backward_ms"})
    EXPECT_GT(row.at(key).get<double>(), 0.0) << key;
}

TEST_F(FitBinaryTest, NoMotionHasNoMotionParameters) {
  const fs::path ws = Workspace("ws_static");
  const fs::path log = ws / "fit.log";
  ASSERT_EQ(RunPano4d("fit --workspace '" + ws.string() +
                          "' --iterations 5 --no-motion",
                      log),
            0)
      << Slurp(log);
  const nlohmann::json fit =
      nlohmann::json::parse(Slurp(ws / "pano4d/fit.json"));
  EXPECT_EQ(fit.at("dynamic_gaussians").get<int>(), 0);
  EXPECT_EQ(fit.at("motion_bases").get<int>(), 0);
}

TEST_F(FitBinaryTest, MissingFramesAndBadOptionsAreOneLineErrors) {
  testing::TempDir empty;
  const fs::path log = empty.path() / "log.txt";
  EXPECT_EQ(RunPano4d("fit --workspace '" + empty.path().string() + "'", log),
            1);
  const std::string err = Slurp(log);
  EXPECT_NE(err.find("frames.json"), std::string::npos) << err;
  EXPECT_NE(err.find("pano4d depth"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_EQ(RunPano4d("fit --workspace '" + empty.path().string() +
                          "' --deterministic --time-budget 10",
                      log),
            1);
}

// Starts pano4d in the background; returns its pid.
pid_t Spawn(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<char*> argv;
  std::vector<std::string> all = {kBinary};
  all.insert(all.end(), args.begin(), args.end());
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, kBinary.c_str(), &actions, nullptr,
                             argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

TEST_F(FitBinaryTest, KilledRunResumesToTheSameResult) {
  // With expansion (steps at 100 and 200, chained), so that the resumed run
  // has to reload the expansion's products.
  const std::vector<std::string> options = {"--iterations",
                                            "400",
                                            "--checkpoint-every",
                                            "25",
                                            "--validate-every",
                                            "200",
                                            "--deterministic",
                                            "--expand-every",
                                            "100",
                                            "--expansion-steps",
                                            "2",
                                            "--directions",
                                            "2",
                                            "--expansion-stride",
                                            "4"};
  // Uninterrupted.
  const fs::path straight = Workspace("ws_straight");
  {
    std::string args = "fit --workspace '" + straight.string() + "'";
    for (const std::string& o : options) args += " " + o;
    ASSERT_EQ(RunPano4d(args, straight / "fit.log"), 0)
        << Slurp(straight / "fit.log");
  }
  // Killed with SIGKILL once the first checkpoint is on disk, then resumed.
  const fs::path killed = Workspace("ws_killed");
  std::vector<std::string> args = {"fit", "--workspace", killed.string()};
  args.insert(args.end(), options.begin(), options.end());
  const pid_t pid = Spawn(args, killed / "fit1.log");
  ASSERT_GT(pid, 0);
  const fs::path ckpt = killed / "pano4d/checkpoints/fit.ckpt";
  const fs::path steps = killed / "pano4d/expansion/steps.json";
  // Once a checkpoint newer than the first expansion step is on disk.
  const auto ready = [&] {
    std::error_code ec;
    return fs::exists(steps, ec) && fs::exists(ckpt, ec) &&
           fs::last_write_time(ckpt, ec) > fs::last_write_time(steps, ec);
  };
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::seconds(300);
  while (!ready() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ASSERT_TRUE(ready()) << Slurp(killed / "fit1.log");
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
      << "the run finished before it could be killed; the test proves "
         "nothing";
  EXPECT_FALSE(fs::exists(killed / "pano4d/fit.json"));
  std::string resume = "fit --workspace '" + killed.string() + "' --resume";
  for (const std::string& o : options) resume += " " + o;
  ASSERT_EQ(RunPano4d(resume, killed / "fit2.log"), 0)
      << Slurp(killed / "fit2.log");
  const nlohmann::json a =
      nlohmann::json::parse(Slurp(straight / "pano4d/fit.json"));
  const nlohmann::json b =
      nlohmann::json::parse(Slurp(killed / "pano4d/fit.json"));
  EXPECT_GT(b.at("resumed_at").get<int>(), 100);
  EXPECT_EQ(a.at("expansion").at("steps").size(), 2u);
  // Steps redone after the resume are not counted twice.
  ASSERT_EQ(b.at("expansion").at("steps").size(), 2u);
  EXPECT_EQ(b["expansion"]["steps"][1].at("step"), 2);
  // The layout's shell came with the checkpoint, not a second time.
  EXPECT_GE(a.at("expansion").at("layout_shell").get<int>(), 0);
  EXPECT_EQ(b.at("expansion").at("layout_shell").get<int>(), 0);
  EXPECT_EQ(a.at("static_gaussians"), b.at("static_gaussians"));
  EXPECT_EQ(a.at("iterations"), b.at("iterations"));
  EXPECT_EQ(a.at("metrics"), b.at("metrics"));
  EXPECT_EQ(a.at("train_psnr"), b.at("train_psnr"));
  // The final state, byte for byte.
  EXPECT_TRUE(ReadFileBytes(straight / "pano4d/checkpoints/fit.ckpt") ==
              ReadFileBytes(ckpt));
}

// Two commands that write one workspace: the second is refused naming the
// first (its command and PID), readers too, and once the first is killed
// (SIGKILL: no chance to clean up) the next command takes the lock over.
TEST_F(FitBinaryTest, ASecondWriterIsRefusedAndAKilledHoldersLockTakenOver) {
  const fs::path ws = Workspace("ws_lock");
  const pid_t pid = Spawn({"fit", "--workspace", ws.string(), "--iterations",
                           "100000", "--no-expansion"},
                          ws / "fit1.log");
  ASSERT_GT(pid, 0);
  const fs::path lock = ws / "pano4d/lock";
  const std::string holder = "\"pid\":" + std::to_string(pid);
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (Slurp(lock).find(holder) == std::string::npos &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_NE(Slurp(lock).find(holder), std::string::npos)
      << Slurp(ws / "fit1.log");
  const std::string ws_arg = " --workspace '" + ws.string() + "'";
  for (const std::string& second :
       {"fit" + ws_arg + " --force --iterations 20",
        "fit" + ws_arg + " --iterations 20",
        "depth" + ws_arg + " --dataset '" + (dir_->path() / "tiny").string() +
            "'",
        "run" + ws_arg + " --dataset '" + (dir_->path() / "tiny").string() +
            "' --iterations 20",
        "render" + ws_arg + " --out '" + (ws / "r").string() + "'"}) {
    const fs::path log = ws / "second.log";
    EXPECT_EQ(RunPano4d(second, log), 1) << second << "\n" << Slurp(log);
    const std::string out = Slurp(log);
    EXPECT_NE(out.find("in use by `pano4d fit --workspace"), std::string::npos)
        << second << "\n"
        << out;
    EXPECT_NE(out.find("PID " + std::to_string(pid)), std::string::npos) << out;
  }
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << Slurp(ws / "fit1.log");
  EXPECT_EQ(RunPano4d("fit" + ws_arg +
                          " --force --iterations 20 "
                          "--no-expansion",
                      ws / "fit2.log"),
            0)
      << Slurp(ws / "fit2.log");
}

// SIGUSR1 (a scheduler's warning) to a plain `fit`: exit 75 as `run` does,
// a report of the iterations done, and --resume goes on from there.
TEST_F(FitBinaryTest, TheStopSignalExits75WithTheIterationsDone) {
  const fs::path ws = Workspace("ws_usr1");
  const fs::path ckpt = ws / "pano4d/checkpoints/fit.ckpt";
  std::vector<std::string> args = {
      "fit",    ws.string(),      "--iterations",
      "100000", "--no-expansion", "--checkpoint-every",
      "5"};
  args.insert(args.begin() + 1, "--workspace");
  // Signalled once a checkpoint newer than `after` is on disk (the fit
  // is in its loop); returns the exit status and the log.
  const auto signalled = [&](const fs::path& log, fs::file_time_type after) {
    const pid_t pid = Spawn(args, log);
    EXPECT_GT(pid, 0);
    const auto ready = [&] {
      std::error_code ec;
      return fs::exists(ckpt, ec) && fs::last_write_time(ckpt, ec) > after;
    };
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!ready() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    kill(pid, SIGUSR1);
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  ASSERT_EQ(signalled(ws / "fit1.log", fs::file_time_type::min()), 75)
      << Slurp(ws / "fit1.log");
  const std::string out = Slurp(ws / "fit1.log");
  EXPECT_EQ(out.find("iterations 0 "), std::string::npos) << out;
  EXPECT_NE(out.find("stopped on request at iteration "), std::string::npos)
      << out;
  EXPECT_NE(out.find("--resume"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(ws / "pano4d/fit.json"));
  // The same command with --resume goes on (and is stopped again).
  args.push_back("--resume");
  ASSERT_EQ(signalled(ws / "fit2.log", fs::last_write_time(ckpt)), 75)
      << Slurp(ws / "fit2.log");
  EXPECT_NE(Slurp(ws / "fit2.log").find("resumed from"), std::string::npos)
      << Slurp(ws / "fit2.log");
}

// Training pairs for a video prior from a workspace's frames and depth.
TEST_F(FitBinaryTest, MakePairsWritesClipsOfCovisibleVideoMasksAndSource) {
  const fs::path ws = Workspace("ws_pairs");
  const fs::path out = ws / "pairs";
  ASSERT_EQ(RunPano4d("make-pairs --workspace '" + ws.string() + "' --out '" +
                          out.string() + "' --clips 2 --frames 6 --seed 4",
                      ws / "pairs.log"),
            0)
      << Slurp(ws / "pairs.log");
  for (const char* clip : {"clip_00000", "clip_00001"}) {
    for (const char* kind : {"cov", "mask", "src"}) {
      int files = 0;
      for (const auto& e : fs::directory_iterator(out / clip / kind))
        files += e.path().extension() == ".png";
      EXPECT_EQ(files, 6) << clip << " " << kind;
    }
    const nlohmann::json meta =
        nlohmann::json::parse(Slurp(out / clip / "meta.json"));
    ASSERT_EQ(meta.at("frames").size(), 6u);
    EXPECT_DOUBLE_EQ(meta["frames"][0].at("angle_degrees").get<double>(), 0);
    EXPECT_NEAR(meta["frames"][5].at("angle_degrees").get<double>(), 30, 1e-9);
  }
  const nlohmann::json report =
      nlohmann::json::parse(Slurp(out / "pairs.json"));
  // The first frame of each clip has not moved; later ones lose something.
  EXPECT_GT(report.at("mask_fraction").get<double>(), 0.01);
  EXPECT_LT(report.at("mask_fraction").get<double>(), 0.9);
}

// A finished fit is never replaced silently: without --resume or --force
// the fit is refused before any work; --force starts again and keeps the
// previous fit until the new one completes.
TEST_F(FitBinaryTest, AFinishedFitIsReplacedOnlyWithForce) {
  const fs::path ws = Workspace("ws_force");
  ASSERT_EQ(RunPano4d("fit --workspace '" + ws.string() +
                          "' --iterations 20 --no-expansion",
                      ws / "fit1.log"),
            0)
      << Slurp(ws / "fit1.log");
  const std::string first = Slurp(ws / "pano4d/fit.json");
  const std::string checkpoint = Slurp(ws / "pano4d/checkpoints/fit.ckpt");
  EXPECT_EQ(RunPano4d("fit --workspace '" + ws.string() +
                          "' --iterations 10 --no-expansion",
                      ws / "fit2.log"),
            1);
  const std::string refused = Slurp(ws / "fit2.log");
  EXPECT_NE(refused.find("fit.ckpt"), std::string::npos) << refused;
  EXPECT_NE(refused.find("--resume"), std::string::npos) << refused;
  EXPECT_NE(refused.find("--force"), std::string::npos) << refused;
  EXPECT_EQ(Slurp(ws / "pano4d/fit.json"), first);
  EXPECT_EQ(Slurp(ws / "pano4d/checkpoints/fit.ckpt"), checkpoint);

  // --force starts again; the backup goes once the new fit completed.
  ASSERT_EQ(RunPano4d("fit --workspace '" + ws.string() +
                          "' --iterations 10 --no-expansion --force",
                      ws / "fit3.log"),
            0)
      << Slurp(ws / "fit3.log");
  const nlohmann::json fit =
      nlohmann::json::parse(Slurp(ws / "pano4d/fit.json"));
  EXPECT_EQ(fit.at("iterations").get<int>(), 10);
  EXPECT_FALSE(fs::exists(ws / "pano4d/previous_fit"));

  // A backup left by a --force run that did not complete is never
  // overwritten.
  fs::create_directories(ws / "pano4d/previous_fit/checkpoints");
  EXPECT_EQ(RunPano4d("fit --workspace '" + ws.string() +
                          "' --iterations 10 --no-expansion --force",
                      ws / "fit4.log"),
            1);
  EXPECT_NE(Slurp(ws / "fit4.log").find("previous_fit"), std::string::npos)
      << Slurp(ws / "fit4.log");
  EXPECT_EQ(nlohmann::json::parse(Slurp(ws / "pano4d/fit.json"))
                .at("iterations")
                .get<int>(),
            10);

  // While a --force fit has not completed, its checkpoint is not there yet
  // and the earlier one is in previous_fit: export says so, not "run pano4d
  // fit first".
  fs::rename(ws / "pano4d/checkpoints/fit.ckpt",
             ws / "pano4d/previous_fit/checkpoints/fit.ckpt");
  EXPECT_EQ(
      RunPano4d("export --workspace '" + ws.string() + "'", ws / "export.log"),
      1);
  const std::string export_log = Slurp(ws / "export.log");
  EXPECT_NE(export_log.find("previous_fit"), std::string::npos) << export_log;
  EXPECT_NE(export_log.find("has not completed"), std::string::npos)
      << export_log;
}

// Ctrl-C while the prior command runs: the command's process group is
// stopped and pano4d ends with the signal within a second; the checkpoint
// resumes, and a prior that sleeps past --prior-timeout is stopped and the
// CPU prior fills in.
TEST_F(FitBinaryTest, InterruptDuringThePriorStopsBothAndTheCheckpointResumes) {
  const fs::path ws = Workspace("ws_interrupt");
  const std::vector<std::string> options = {
      "--iterations", "40", "--checkpoint-every", "10", "--expand-every", "20",
      "--expansion-steps", "1", "--directions", "1", "--expansion-stride", "4",
      "--panorama-width", "64", "--prior-cmd",
      // The wait policy pano4d runs with (main.cc), then a hang.
      "echo $OMP_WAIT_POLICY > '" + (ws / "policy.txt").string() +
          "'; sleep 60 # {in} {out}"};
  std::vector<std::string> args = {"fit", "--workspace", ws.string()};
  args.insert(args.end(), options.begin(), options.end());
  const pid_t pid = Spawn(args, ws / "fit1.log");
  ASSERT_GT(pid, 0);
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (Slurp(ws / "fit1.log").find("prior command for clip") ==
             std::string::npos &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_NE(Slurp(ws / "fit1.log").find("prior command for clip"),
            std::string::npos)
      << Slurp(ws / "fit1.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // sleeping
  const auto sent = std::chrono::steady_clock::now();
  kill(pid, SIGINT);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0 &&
         std::chrono::steady_clock::now() - sent < std::chrono::seconds(30))
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - sent)
          .count();
  std::printf("SIGINT to exit: %.3f s\n", seconds);
  EXPECT_LT(seconds, 1.0) << Slurp(ws / "fit1.log");
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGINT)
      << "status " << status << "\n"
      << Slurp(ws / "fit1.log");
  EXPECT_FALSE(fs::exists(ws / "pano4d/fit.json"));
  // OpenMP's threads sleep rather than spin unless the user said otherwise.
  const char* policy = std::getenv("OMP_WAIT_POLICY");
  EXPECT_EQ(Slurp(ws / "policy.txt"),
            std::string(policy ? policy : "passive") + "\n");

  std::string resume = "fit --workspace '" + ws.string() + "' --resume";
  for (const std::string& o : options) {
    std::string quoted;  // for the shell: ' becomes '\''
    for (char c : o)
      quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
    resume += " '" + quoted + "'";
  }
  resume += " --prior-timeout 1";
  ASSERT_EQ(RunPano4d(resume, ws / "fit2.log"), 0) << Slurp(ws / "fit2.log");
  const std::string log = Slurp(ws / "fit2.log");
  EXPECT_NE(log.find("resumed from"), std::string::npos) << log;
  EXPECT_NE(log.find("stopped at its time limit of 1 s"), std::string::npos)
      << log;
  EXPECT_NE(log.find("falling back to the geometry prior"), std::string::npos)
      << log;
  EXPECT_EQ(nlohmann::json::parse(Slurp(ws / "pano4d/fit.json"))
                .at("iterations")
                .get<int>(),
            40);
}

// A checkpoint copied from another scene whose frames have the same names,
// and one with a flipped bit: --resume refuses both by name, and the
// workspace's own checkpoint still resumes.
TEST_F(FitBinaryTest, ResumeRefusesAnotherScenesOrACorruptCheckpoint) {
  const fs::path other = dir_->path() / "tiny_other";
  ASSERT_EQ(
      RunPano4d("synth --preset tiny --seed 4 --out '" + other.string() + "'",
                dir_->path() / "synth_other.log"),
      0);
  const fs::path ws = Workspace("ws_own");
  const fs::path ws_other = dir_->path() / "ws_other";
  ASSERT_EQ(RunPano4d("depth --workspace '" + ws_other.string() +
                          "' --dataset '" + other.string() + "'",
                      dir_->path() / "depth_other.log"),
            0);
  const std::string fit = " --iterations 10 --no-expansion";
  for (const fs::path& w : {ws, ws_other}) {
    ASSERT_EQ(
        RunPano4d("fit --workspace '" + w.string() + "'" + fit, w / "fit.log"),
        0)
        << Slurp(w / "fit.log");
  }
  const fs::path ckpt = ws / "pano4d/checkpoints/fit.ckpt";
  const std::string own = Slurp(ckpt);
  const auto resume = [&](const std::string& bytes) {
    {
      std::ofstream out(ckpt, std::ios::binary | std::ios::trunc);
      out << bytes;
    }
    const int rc = RunPano4d(
        "fit --workspace '" + ws.string() + "' --resume" + fit, ws / "r.log");
    return std::make_pair(rc, Slurp(ws / "r.log"));
  };
  const auto [rc_other, log_other] =
      resume(Slurp(ws_other / "pano4d/checkpoints/fit.ckpt"));
  EXPECT_EQ(rc_other, 1) << log_other;
  EXPECT_NE(log_other.find("fit.ckpt: field 'scene'"), std::string::npos)
      << log_other;
  std::string flipped = own;
  flipped[flipped.size() / 2] ^= 0x04;
  const auto [rc_flip, log_flip] = resume(flipped);
  EXPECT_EQ(rc_flip, 1) << log_flip;
  EXPECT_NE(log_flip.find("checksum"), std::string::npos) << log_flip;
  // Options that shape the model, given on resume, are refused by name
  // (before, --num-bases, --sh-degree and --no-motion were ignored).
  for (const auto& [flag, field] :
       std::vector<std::pair<std::string, std::string>>{
           {" --num-bases 3", "init.num_bases"},
           {" --no-motion", "init.num_bases"},
           {" --sh-degree 1", "init.sh_degree"}}) {
    {
      std::ofstream out(ckpt, std::ios::binary | std::ios::trunc);
      out << own;
    }
    EXPECT_EQ(
        RunPano4d("fit --workspace '" + ws.string() + "' --resume" + fit + flag,
                  ws / "r.log"),
        1)
        << flag;
    EXPECT_NE(Slurp(ws / "r.log").find("option " + field), std::string::npos)
        << Slurp(ws / "r.log");
  }
  const auto [rc_own, log_own] = resume(own);
  EXPECT_EQ(rc_own, 0) << log_own;
  EXPECT_NE(log_own.find("resumed from"), std::string::npos) << log_own;
}

// Expansion products where users and viewers look for them, and a video
// prior that fails: the CPU prior fills in, the log says why, the fit ends.
TEST_F(FitBinaryTest, ExpansionWritesItsProductsAndSurvivesAFailingPrior) {
  const fs::path ws = Workspace("ws_expansion");
  const fs::path log = ws / "fit.log";
  ASSERT_EQ(RunPano4d("fit --workspace '" + ws.string() +
                          "' --iterations 60 --expand-every 20 "
                          "--expansion-steps 2 --directions 2 "
                          "--expansion-stride 4 --panorama-width 128 "
                          "--prior-cmd '" PANO4D_FAKE_PRIOR " fail {in} {out}'",
                      log),
            0)
      << Slurp(log);
  const std::string text = Slurp(log);
  EXPECT_NE(text.find("falling back to the geometry prior"), std::string::npos)
      << text;
  const nlohmann::json fit =
      nlohmann::json::parse(Slurp(ws / "pano4d/fit.json"));
  const nlohmann::json& steps = fit.at("expansion").at("steps");
  ASSERT_EQ(steps.size(), 2u);
  // The synthetic dataset gives depth: the frames are warped with it.
  EXPECT_EQ(fit["expansion"].at("options").at("warp_depth"), "given");
  EXPECT_NE(text.find("expansion warps with given depth"), std::string::npos);
  EXPECT_GT(steps[0].at("fallbacks").get<int>(), 0);
  EXPECT_GT(steps[1].at("prefilled_fraction").get<double>(), 0.0);
  const fs::path e = ws / "pano4d/expansion";
  // tiny: 8 frames, every 4th expanded: 2 directions x 2 steps x 2 frames.
  const nlohmann::json traj =
      nlohmann::json::parse(Slurp(e / "trajectories.json"));
  EXPECT_EQ(traj.at("views").size(), 8u);
  const std::string images = Slurp(e / "colmap/images.txt");
  EXPECT_NE(images.find("source/"), std::string::npos);
  EXPECT_NE(images.find("step_02/dir_1/0_00004.png"), std::string::npos);
  EXPECT_TRUE(fs::exists(e / "colmap/cameras.txt"));
  EXPECT_TRUE(fs::exists(e / "step_02/dir_1/refined/0_00004.png"));
  EXPECT_TRUE(fs::exists(ws / "pano4d/panorama/static.png"));
  EXPECT_TRUE(fs::exists(ws / "pano4d/panorama/00007.png"));
  // The inputs the prior got are kept for inspection.
  EXPECT_TRUE(fs::exists(e / "prior/step01_dir0/in/meta.json"));

  // `pano4d expand`: one step at a time on the fitted Gaussians, chained.
  const std::string expand = "expand --workspace '" + ws.string() +
                             "' --directions 2 --expansion-steps 2 "
                             "--expansion-stride 4 --panorama-width 64";
  ASSERT_EQ(RunPano4d(expand, ws / "expand1.log"), 0)
      << Slurp(ws / "expand1.log");
  ASSERT_EQ(RunPano4d(expand, ws / "expand2.log"), 0)
      << Slurp(ws / "expand2.log");
  const nlohmann::json expand_steps =
      nlohmann::json::parse(Slurp(ws / "pano4d/expand/steps.json"));
  ASSERT_EQ(expand_steps.size(), 2u);
  EXPECT_EQ(expand_steps[1].at("step").get<int>(), 2);
  EXPECT_GT(expand_steps[1].at("prefilled_fraction").get<double>(), 0.0);
  EXPECT_TRUE(
      fs::exists(ws / "pano4d/expand/step_02/dir_0/refined/0_00000.png"));
  EXPECT_TRUE(fs::exists(ws / "pano4d/expand/colmap/images.txt"));
  EXPECT_EQ(RunPano4d(expand, ws / "expand3.log"), 1);
  EXPECT_NE(Slurp(ws / "expand3.log").find("all 2 steps have run"),
            std::string::npos)
      << Slurp(ws / "expand3.log");

  // --no-expansion: the same fit without it.
  const fs::path plain = Workspace("ws_no_expansion");
  ASSERT_EQ(RunPano4d("fit --workspace '" + plain.string() +
                          "' --iterations 60 --expand-every 20 --no-expansion",
                      plain / "fit.log"),
            0);
  const nlohmann::json fit2 =
      nlohmann::json::parse(Slurp(plain / "pano4d/fit.json"));
  EXPECT_TRUE(fit2.at("expansion").is_null());
  EXPECT_FALSE(fs::exists(plain / "pano4d/expansion"));
  EXPECT_LT(fit2.at("static_gaussians").get<int>(),
            fit.at("static_gaussians").get<int>());
  // --no-gaussian-refinement: the Gaussians fit as without expansion, and
  // validation scores the panorama results instead of their renders.
  const fs::path panorama = Workspace("ws_panorama_only");
  ASSERT_EQ(RunPano4d("fit --workspace '" + panorama.string() +
                          "' --iterations 60 --expand-every 20 "
                          "--expansion-steps 2 --directions 2 "
                          "--expansion-stride 4 --panorama-width 64 "
                          "--no-gaussian-refinement --warp-depth rendered",
                      panorama / "fit.log"),
            0)
      << Slurp(panorama / "fit.log");
  EXPECT_NE(Slurp(panorama / "fit.log").find("the panorama results"),
            std::string::npos);
  const nlohmann::json fit3 =
      nlohmann::json::parse(Slurp(panorama / "pano4d/fit.json"));
  EXPECT_EQ(fit3.at("static_gaussians"), fit2.at("static_gaussians"));
  EXPECT_EQ(fit3.at("expansion").at("steps").size(), 2u);
  EXPECT_EQ(fit3["expansion"].at("options").at("warp_depth"), "rendered");
  EXPECT_EQ(RunPano4d("fit --workspace '" + panorama.string() +
                          "' --warp-depth sensor",
                      panorama / "bad.log"),
            64)
      << Slurp(panorama / "bad.log");
  int differ = 0, renders = 0;
  for (const auto& f : fs::directory_iterator(plain / "pano4d/renders/val")) {
    ++renders;
    differ += Slurp(f.path()) !=
              Slurp(panorama / "pano4d/renders/val" / f.path().filename());
  }
  EXPECT_EQ(renders, 16);
  EXPECT_EQ(differ, renders);
  EXPECT_TRUE(fit3.at("metrics").at("upsnr").is_number());

  // expand needs a fit first, and says so.
  const fs::path bare = Workspace("ws_expand_first");
  EXPECT_EQ(RunPano4d("expand --workspace '" + bare.string() + "'",
                      bare / "expand.log"),
            1);
  EXPECT_NE(Slurp(bare / "expand.log").find("fit.ckpt"), std::string::npos);
}

}  // namespace
}  // namespace pano4d
