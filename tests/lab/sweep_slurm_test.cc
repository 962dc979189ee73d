// `pano4d sweep` on a real Slurm: a single-node cluster on localhost
// (scripts/slurm_local.sh: munged, slurmctld, slurmd, configured in a
// temporary folder and stopped at the end), the tiny scene x 2 seeds x 2
// configurations as a job array, collected and compared with `sweep
// local` on the same plan; then a task cancelled mid-run and the array
// resubmitted, which finishes it without refitting the entries done.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/subprocess.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using testing::RunLogged;
using testing::RunPano4d;
using testing::Slurp;

const std::string kScript =
    std::string(PANO4D_SOURCE_DIR) + "/scripts/slurm_local.sh";
// How long a sweep of the tiny scene may take on the test cluster.
constexpr double kSweepSeconds = 400.0;

// The cluster for one test, stopped however the test ends.
class LocalSlurm {
 public:
  explicit LocalSlurm(fs::path dir) : dir_(std::move(dir)) {
    started_ = RunLogged("bash '" + kScript + "' start '" + dir_.string() + "'",
                         dir_.string() + ".start.log") == 0;
    if (started_) setenv("SLURM_CONF", (dir_ / "slurm.conf").c_str(), 1);
  }
  ~LocalSlurm() {
    RunLogged("bash '" + kScript + "' stop '" + dir_.string() + "'",
              dir_.string() + ".stop.log");
    unsetenv("SLURM_CONF");
  }
  bool started() const { return started_; }
  std::string log() const { return Slurp(dir_.string() + ".start.log"); }

 private:
  fs::path dir_;
  bool started_ = false;
};

// Submits SWEEP's batch script; the job id.
std::string Submit(const fs::path& sweep, const std::string& flags,
                   const fs::path& log) {
  EXPECT_EQ(
      RunPano4d("sweep sbatch '" + sweep.string() + "' " + flags + " --submit",
                log),
      0)
      << Slurp(log);
  const std::string out = Slurp(log);
  const std::size_t at = out.find("submitted job ");
  if (at == std::string::npos) return "";
  std::istringstream in(out.substr(at + 14));
  std::string id;
  in >> id;
  return id;
}

// Waits until `job` has left the queue (or `ready` holds, when given).
bool WaitFor(const std::string& job, const fs::path& scratch,
             const std::function<bool()>& ready = nullptr) {
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
             .count() < kSweepSeconds) {
    if (ready && ready()) return true;
    RunLogged("squeue -h -j " + job, scratch);
    if (!ready && Slurp(scratch).find_first_not_of(" \n") == std::string::npos)
      return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  return false;
}

// sweep.csv without the columns that differ between runs (seconds, peak
// memory, attempts).
std::string Metrics(const fs::path& sweep) {
  std::istringstream in(Slurp(sweep / "sweep.csv"));
  std::string out;
  for (std::string line; std::getline(in, line);) {
    for (int i = 0; i < 3; ++i) line = line.substr(0, line.rfind(','));
    out += line + "\n";
  }
  return out;
}

TEST(SweepSlurmTest, AJobArrayCompletesResumesAfterScancelAndMatchesLocal) {
  if (geteuid() != 0 || !FindOnPath("slurmctld") || !FindOnPath("munged")) {
    GTEST_SKIP() << "SLURM MISSING: the Slurm test needs root and Debian's "
                    "slurm-wlm and munge (`bash scripts/setup.sh` installs "
                    "them)";
  }
  testing::TempDir dir;
  LocalSlurm slurm(dir / "cluster");
  ASSERT_TRUE(slurm.started()) << slurm.log();
  ASSERT_EQ(RunPano4d("synth --preset tiny --seed 3 --out '" +
                          (dir / "root" / "tiny").string() + "'",
                      dir / "synth.log"),
            0)
      << Slurp(dir / "synth.log");
  const std::string plan = "sweep plan --root '" + (dir / "root").string() +
                           "' --seeds 0,1 --configs default,no-expansion "
                           "--iterations 60 --deterministic --out ";
  const fs::path on_slurm = dir / "on_slurm", on_this = dir / "local";
  ASSERT_EQ(RunPano4d(plan + "'" + on_slurm.string() + "'", dir / "plan.log"),
            0);
  ASSERT_EQ(RunPano4d(plan + "'" + on_this.string() + "'", dir / "plan.log"),
            0);

  // The array on Slurm, then the same plan locally.
  const std::string job =
      Submit(on_slurm, "--cpus 1 --max-parallel 2", dir / "submit.log");
  ASSERT_FALSE(job.empty()) << Slurp(dir / "submit.log");
  ASSERT_TRUE(WaitFor(job, dir / "squeue.txt")) << "job " << job;
  ASSERT_EQ(RunPano4d("sweep collect '" + on_slurm.string() + "'",
                      dir / "collect.log"),
            0);
  EXPECT_NE(Slurp(dir / "collect.log").find("4 entries, 4 done"),
            std::string::npos)
      << Slurp(dir / "collect.log") << Slurp(on_slurm / "logs" / "0.log");
  ASSERT_EQ(RunPano4d("sweep local '" + on_this.string() + "' --jobs 2",
                      dir / "local.log"),
            0)
      << Slurp(dir / "local.log");
  ASSERT_EQ(RunPano4d("sweep collect '" + on_this.string() + "'",
                      dir / "collect.log"),
            0);
  // One row per entry plus the header, the same metrics both ways.
  const std::string metrics = Metrics(on_slurm);
  EXPECT_EQ(std::count(metrics.begin(), metrics.end(), '\n'), 5) << metrics;
  EXPECT_EQ(metrics, Metrics(on_this));

  // A longer sweep, one task at a time: task 0 cancelled while it fits.
  const fs::path cancelled = dir / "cancelled";
  ASSERT_EQ(RunPano4d("sweep plan --root '" + (dir / "root").string() +
                          "' --seeds 0,1 --iterations 1500 --out '" +
                          cancelled.string() + "'",
                      dir / "plan.log"),
            0);
  const std::string second =
      Submit(cancelled, "--cpus 1 --max-parallel 1", dir / "submit.log");
  ASSERT_FALSE(second.empty()) << Slurp(dir / "submit.log");
  ASSERT_TRUE(WaitFor(second, dir / "squeue.txt", [&] {
    return Slurp(cancelled / "logs" / "0.log").find("fit [") !=
           std::string::npos;
  })) << "task 0 never started fitting";
  ASSERT_EQ(RunLogged("scancel " + second + "_0", dir / "scancel.log"), 0)
      << Slurp(dir / "scancel.log");
  ASSERT_TRUE(WaitFor(second, dir / "squeue.txt"));
  Json status0 = ReadJson(cancelled / "status" / "0.json");
  Json status1 = ReadJson(cancelled / "status" / "1.json");
  // scancel sends SIGTERM first: the entry's run checkpoints and the status
  // says so (a SIGKILL before it could write would leave "running").
  EXPECT_EQ(status0["status"], "stopped")
      << "cancelled mid-run: " << status0.dump();
  EXPECT_NE(status0.value("error", "").find("resumes"), std::string::npos)
      << status0.dump();
  ASSERT_EQ(status1["status"], "done") << status1.dump();
  // Resubmitted: entry 0 runs again, entry 1 is not refitted.
  const std::string third =
      Submit(cancelled, "--cpus 1 --max-parallel 1", dir / "submit.log");
  ASSERT_TRUE(WaitFor(third, dir / "squeue.txt"));
  status0 = ReadJson(cancelled / "status" / "0.json");
  EXPECT_EQ(status0["status"], "done") << status0.dump();
  EXPECT_EQ(status0["attempts"], 2);
  EXPECT_EQ(ReadJson(cancelled / "status" / "1.json"), status1);
  ASSERT_EQ(RunPano4d("sweep collect '" + cancelled.string() + "'",
                      dir / "collect.log"),
            0);
  EXPECT_NE(Slurp(dir / "collect.log").find("2 entries, 2 done"),
            std::string::npos)
      << Slurp(dir / "collect.log");
}

}  // namespace
}  // namespace pano4d
