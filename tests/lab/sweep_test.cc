// `pano4d sweep` as a lab runs it, without a cluster: plan, run one entry
// by index (also from $SLURM_ARRAY_TASK_ID), local, collect with a failing
// entry, the batch script. The real Slurm test is sweep_slurm_test.cc.
#include "src/lab/sweep.h"

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/npy.h"
#include "src/core/workspace_lock.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using testing::RunLogged;
using testing::RunPano4d;
using testing::Slurp;

const std::string kPano4d = std::string(PANO4D_BINARY_DIR) + "/pano4d";

class SweepTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    ASSERT_EQ(RunPano4d("synth --preset tiny --seed 3 --out '" +
                            (dir_->path() / "root" / "tiny").string() + "'",
                        dir_->path() / "synth.log"),
              0)
        << Slurp(dir_->path() / "synth.log");
  }
  static void TearDownTestSuite() { delete dir_; }
  static testing::TempDir* dir_;
};
testing::TempDir* SweepTest::dir_ = nullptr;

TEST_F(SweepTest, PlanRunLocalCollectWithAFailingEntry) {
  const fs::path sweep = dir_->path() / "sweep";
  const fs::path log = dir_->path() / "sweep.log";
  ASSERT_EQ(RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                          "' --seeds 0,1 --configs default,no-expansion "
                          "--iterations 40 --deterministic --out '" +
                          sweep.string() + "'",
                      log),
            0)
      << Slurp(log);
  const Json manifest = ReadJson(sweep / "manifest.json");
  ASSERT_EQ(manifest["entries"].size(), 4u);
  for (const Json& e : manifest["entries"]) {
    const auto command = e["command"].get<std::vector<std::string>>();
    EXPECT_NE(std::find(command.begin(), command.end(), "--seed"),
              command.end());
    EXPECT_EQ(std::find(command.begin(), command.end(), "--no-expansion") !=
                  command.end(),
              e["config"] == "no-expansion");
  }
  // Entry 1 from the array task's index; a second run does nothing.
  ASSERT_EQ(RunLogged("SLURM_ARRAY_TASK_ID=1 " + kPano4d + " sweep run '" +
                          sweep.string() + "'",
                      log),
            0)
      << Slurp(log);
  Json status = ReadJson(sweep / "status" / "1.json");
  EXPECT_EQ(status["status"], "done");
  EXPECT_EQ(status["attempts"], 1);
  EXPECT_GT(status["peak_memory_mib"].get<double>(), 0.0);
  ASSERT_EQ(RunPano4d("sweep run '" + sweep.string() + "' --index 1", log), 0);
  EXPECT_NE(Slurp(log).find("finished earlier"), std::string::npos)
      << Slurp(log);
  EXPECT_EQ(ReadJson(sweep / "status" / "1.json")["attempts"], 1);
  // Entry 2's workspace is made unusable: its run fails.
  const fs::path ws2 = manifest["entries"][2]["workspace"].get<std::string>();
  fs::create_directories(ws2.parent_path());
  testing::WriteText(ws2, "a file where the workspace folder should be");
  EXPECT_EQ(RunPano4d("sweep local '" + sweep.string() + "' --jobs 2", log), 1)
      << Slurp(log);
  ASSERT_EQ(RunPano4d("sweep collect '" + sweep.string() + "'", log), 0)
      << Slurp(log);
  const std::string md = Slurp(sweep / "sweep.md");
  const std::string csv = Slurp(sweep / "sweep.csv");
  EXPECT_NE(Slurp(log).find("4 entries, 3 done, 1 failed"), std::string::npos)
      << Slurp(log);
  // The failure is listed with its error, and its row stays in the table.
  EXPECT_NE(md.find("## Not done"), std::string::npos);
  EXPECT_NE(md.find("2 tiny no-expansion seed 0: failed"), std::string::npos)
      << md;
  EXPECT_NE(csv.find(",failed,"), std::string::npos) << csv;
  EXPECT_NE(md.find("| tiny | synth | pano4d default, mean of 2 of 2 seeds |"),
            std::string::npos)
      << md;
  EXPECT_NE(
      md.find("| tiny | synth | pano4d no-expansion, mean of 1 of 2 seeds |"),
      std::string::npos)
      << md;
  EXPECT_NE(md.find("| tiny | synth | pano4d default, spread |"),
            std::string::npos)
      << md;
}

// A manifest is a file passed between people on a cluster: it holds
// pano4d's `run` arguments and nothing else, and a broken one is refused
// naming the file and the field (not a crash, not a half-written status).
TEST_F(SweepTest, ManifestsAreCheckedAgainstTheirSchema) {
  const fs::path sweep = dir_->path() / "sweep_schema";
  const fs::path log = dir_->path() / "schema.log";
  ASSERT_EQ(RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                          "' --seeds 0,1 --out '" + sweep.string() + "'",
                      log),
            0)
      << Slurp(log);
  const fs::path file = sweep / "manifest.json";
  const Json planned = ReadJson(file);
  EXPECT_EQ(planned["entries"][0]["command"][0], "run");
  const fs::path marker = dir_->path() / "schema_ran";
  struct Case {
    std::string what, expected;
    std::function<void(Json*)> edit;
  };
  const std::vector<Case> cases = {
      {"no config", "entries[0]",
       [](Json* m) { (*m)["entries"][0].erase("config"); }},
      {"no scene", "entries[0]",
       [](Json* m) { (*m)["entries"][0].erase("scene"); }},
      {"no seed", "entries[0]",
       [](Json* m) { (*m)["entries"][0].erase("seed"); }},
      {"a program", "entries[0].command",
       [&](Json* m) {
         (*m)["entries"][0]["command"] = {"/bin/sh", "-c",
                                          "touch '" + marker.string() + "'"};
       }},
      {"a flag that runs a program", "--prior-cmd",
       [&](Json* m) {
         auto& c = (*m)["entries"][0]["command"];
         c.push_back("--prior-cmd");
         c.push_back("touch '" + marker.string() + "'");
       }},
      {"another workspace", "--workspace",
       [](Json* m) { (*m)["entries"][0]["workspace"] = "/tmp/elsewhere"; }},
      {"a duplicated index", "entries[1].index",
       [](Json* m) { (*m)["entries"][1]["index"] = 0; }},
      {"version 1", "version", [](Json* m) { (*m)["version"] = 1; }},
      {"no entries", "no entries",
       [](Json* m) { (*m)["entries"] = Json::array(); }},
  };
  for (const Case& c : cases) {
    Json m = planned;
    c.edit(&m);
    WriteJson(file, m);
    EXPECT_EQ(RunPano4d("sweep run '" + sweep.string() + "' --index 0", log), 1)
        << c.what << ": " << Slurp(log);
    const std::string out = Slurp(log);
    EXPECT_NE(out.find(c.expected), std::string::npos) << c.what << ": " << out;
    if (c.what != "no entries") {
      EXPECT_NE(out.find("manifest.json"), std::string::npos) << c.what;
    }
    EXPECT_FALSE(fs::exists(marker)) << c.what;
    EXPECT_FALSE(fs::exists(sweep / "status" / "0.json")) << c.what;
  }
}

// Two `sweep run` of one entry (a requeued task beside its first
// attempt): the second is refused before it touches the status.
TEST_F(SweepTest, AnEntryRunsInOneProcessAtATime) {
  const fs::path sweep = dir_->path() / "sweep_lock";
  const fs::path log = dir_->path() / "lock.log";
  ASSERT_EQ(RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                          "' --iterations 20 --out '" + sweep.string() + "'",
                      log),
            0)
      << Slurp(log);
  {
    const FolderLock first(sweep / "status" / "0.lock",
                           FolderLock::Mode::kExclusive,
                           "pano4d sweep run (first)");
    EXPECT_EQ(RunPano4d("sweep run '" + sweep.string() + "' --index 0", log),
              1);
    EXPECT_NE(Slurp(log).find("in use by `pano4d sweep run (first)`"),
              std::string::npos)
        << Slurp(log);
    EXPECT_FALSE(fs::exists(sweep / "status" / "0.json"));
  }
  EXPECT_EQ(RunPano4d("sweep run '" + sweep.string() + "' --index 0", log), 0)
      << Slurp(log);
}

// `sweep local` passes SIGTERM (and SIGUSR1) on to the entry it runs,
// waits for it, starts no other, and ends as the signal says: no entry is
// left running behind it.
TEST_F(SweepTest, SweepLocalPassesSignalsOnAndWaits) {
  for (const std::string signal : {"TERM", "USR1"}) {
    const fs::path sweep = dir_->path() / ("sweep_local_" + signal);
    const fs::path log = dir_->path() / ("local_" + signal + ".log");
    ASSERT_EQ(
        RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                      "' --seeds 0,1 --iterations 100000 --out '" +
                      sweep.string() + "'",
                  log),
        0)
        << Slurp(log);
    const fs::path lock =
        fs::path(ReadJson(sweep / "manifest.json")["entries"][0]["workspace"]
                     .get<std::string>()) /
        "pano4d" / "lock";
    // Signalled once entry 0's `pano4d run` holds its workspace and fits.
    const std::string script =
        "(" + kPano4d + " sweep local '" + sweep.string() +
        "' --jobs 1 & pid=$!; n=0; until grep -q '\"pid\"' '" + lock.string() +
        "' 2>/dev/null || [ $n -gt 600 ]; do sleep 0.1; "
        "n=$((n+1)); done; sleep 2; kill -" +
        signal +
        " $pid; wait $pid; echo \"local exit $?\"; rp=$(grep -o "
        "'\"pid\":[0-9]*' '" +
        lock.string() +
        "' | cut -d: -f2); "
        "if kill -0 $rp 2>/dev/null; then echo 'run alive'; else echo "
        "'run gone'; fi)";
    RunLogged(script, log);
    const std::string out = Slurp(log);
    EXPECT_NE(out.find(signal == "TERM" ? "local exit 143" : "local exit 75"),
              std::string::npos)
        << out;
    EXPECT_NE(out.find("run gone"), std::string::npos) << out;
    const Json status = ReadJson(sweep / "status" / "0.json");
    EXPECT_EQ(status["status"], "stopped") << status.dump();
    EXPECT_FALSE(fs::exists(sweep / "status" / "1.json"));
  }
}

// A status file of the wrong types (a hand edit) is named and taken as no
// status, not a raw JSON-library error that stops collect.
TEST_F(SweepTest, AStatusOfTheWrongTypesIsNamedAndIgnored) {
  const fs::path sweep = dir_->path() / "sweep_bad_status";
  const fs::path log = dir_->path() / "bad_status.log";
  ASSERT_EQ(RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                          "' --out '" + sweep.string() + "'",
                      log),
            0)
      << Slurp(log);
  const Json entry = ReadJson(sweep / "manifest.json")["entries"][0];
  WriteJson(sweep / "status" / "0.json", {{"index", 0},
                                          {"command", entry["command"]},
                                          {"status", "done"},
                                          {"seconds", "abc"}});
  ASSERT_EQ(RunPano4d("sweep collect '" + sweep.string() + "'", log), 0)
      << Slurp(log);
  EXPECT_NE(Slurp(log).find("0.json: field 'seconds'"), std::string::npos)
      << Slurp(log);
  EXPECT_NE(Slurp(log).find("1 entries, 0 done"), std::string::npos)
      << Slurp(log);
}

// Planning again into a folder leaves the earlier statuses there: collect
// must not show them as this plan's results.
TEST_F(SweepTest, AStatusOfAnEarlierPlanIsStale) {
  const fs::path sweep = dir_->path() / "sweep_stale";
  const fs::path log = dir_->path() / "stale.log";
  const std::string plan = "sweep plan --root '" +
                           (dir_->path() / "root").string() + "' --out '" +
                           sweep.string() + "' --iterations ";
  ASSERT_EQ(RunPano4d(plan + "30", log), 0) << Slurp(log);
  ASSERT_EQ(RunPano4d("sweep run '" + sweep.string() + "' --index 0", log), 0)
      << Slurp(log);
  ASSERT_EQ(RunPano4d("sweep collect '" + sweep.string() + "'", log), 0);
  EXPECT_NE(Slurp(log).find("1 entries, 1 done"), std::string::npos)
      << Slurp(log);
  ASSERT_EQ(RunPano4d(plan + "40", log), 0) << Slurp(log);
  ASSERT_EQ(RunPano4d("sweep collect '" + sweep.string() + "'", log), 0);
  EXPECT_NE(Slurp(log).find("1 entries, 0 done"), std::string::npos)
      << Slurp(log);
  EXPECT_NE(Slurp(sweep / "sweep.md").find("stale"), std::string::npos)
      << Slurp(sweep / "sweep.md");
}

// Every configuration's flags are ones `pano4d run` takes with its other
// defaults.
TEST_F(SweepTest, EveryConfigurationRuns) {
  const fs::path sweep = dir_->path() / "sweep_configs";
  const fs::path log = dir_->path() / "configs.log";
  std::string configs;
  for (const auto& [name, flags] : SweepConfigs())
    configs += (configs.empty() ? "" : ",") + name;
  ASSERT_EQ(RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                          "' --configs " + configs +
                          " --iterations 30 --out '" + sweep.string() + "'",
                      log),
            0)
      << Slurp(log);
  EXPECT_EQ(RunPano4d("sweep local '" + sweep.string() + "' --jobs 2", log), 0)
      << Slurp(log);
  ASSERT_EQ(RunPano4d("sweep collect '" + sweep.string() + "'", log), 0);
  EXPECT_NE(Slurp(sweep / "sweep.md").find("Every entry finished."),
            std::string::npos)
      << Slurp(sweep / "sweep.md");
}

TEST_F(SweepTest, TheBatchScriptIsAnArrayThatRequeuesOnTheStopSignal) {
  const fs::path sweep = dir_->path() / "sweep_sbatch";
  const fs::path log = dir_->path() / "sbatch.log";
  ASSERT_EQ(RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                          "' --seeds 0,1,2 --configs default,planar --out '" +
                          sweep.string() + "'",
                      log),
            0)
      << Slurp(log);
  ASSERT_EQ(RunPano4d("sweep sbatch '" + sweep.string() +
                          "' --partition cpu --cpus 4 --mem 8G --time 01:00:00 "
                          "--max-parallel 3",
                      log),
            0)
      << Slurp(log);
  const std::string script = Slurp(sweep / "sweep.sbatch");
  for (const char* line :
       {"#SBATCH --array=0-5%3", "#SBATCH --requeue",
        "#SBATCH --signal=B:USR1@", "#SBATCH --partition=cpu",
        "#SBATCH --cpus-per-task=4", "#SBATCH --mem=8G",
        "#SBATCH --time=01:00:00", "scontrol requeue", "sweep run"})
    EXPECT_NE(script.find(line), std::string::npos) << line << "\n" << script;
  // bash reads it.
  EXPECT_EQ(
      RunLogged("bash -n '" + (sweep / "sweep.sbatch").string() + "'", log), 0)
      << Slurp(log);
}

// SIGUSR1 (a scheduler's warning before the time limit): the fit saves
// its checkpoint and run exits 75; the same command resumes it.
TEST_F(SweepTest, TheStopSignalCheckpointsAndTheRerunResumes) {
  const fs::path ws = dir_->path() / "ws_signal";
  const fs::path log = dir_->path() / "signal.log";
  const std::string run =
      kPano4d + " run --dataset '" + (dir_->path() / "root" / "tiny").string() +
      "' --workspace '" + ws.string() + "' --iterations 20000";
  // The run, sent the signal 3 s after it starts; its exit status.
  const std::string signalled =
      "(" + run + " & pid=$!; sleep 3; kill -USR1 $pid; wait $pid; exit $?)";
  ASSERT_EQ(RunLogged(signalled, log), 75) << Slurp(log);
  EXPECT_NE(Slurp(log).find("stopped on request"), std::string::npos)
      << Slurp(log);
  EXPECT_TRUE(fs::exists(ws / "pano4d/checkpoints/fit.ckpt"));
  EXPECT_FALSE(fs::exists(ws / "pano4d/fit.json"));
  // The same command goes on from the checkpoint (stopped again here, to
  // keep the test short).
  ASSERT_EQ(RunLogged(signalled, log), 75) << Slurp(log);
  EXPECT_NE(Slurp(log).find("fit: resumed from"), std::string::npos)
      << Slurp(log);
}

// --priors ROOT: an entry whose scene has priors under ROOT/<scene> runs
// with them; one without runs without.
TEST_F(SweepTest, PriorsReachTheEntriesThatHaveThem) {
  const fs::path priors = dir_->path() / "priors";
  NpyArray disparity =
      NpyArray::FromFloats({48, 64}, std::vector<float>(48 * 64, 1.0f));
  WriteNpy(priors / "tiny" / "disp" / "0_00000.npy", disparity);
  const fs::path sweep = dir_->path() / "sweep_priors";
  const fs::path log = dir_->path() / "sweep_priors.log";
  ASSERT_EQ(RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                          "' --priors '" + priors.string() + "' --out '" +
                          sweep.string() + "'",
                      log),
            0)
      << Slurp(log);
  const auto command =
      ReadJson(sweep / "manifest.json")["entries"][0]["command"]
          .get<std::vector<std::string>>();
  const auto at = std::find(command.begin(), command.end(), "--priors");
  ASSERT_NE(at, command.end());
  EXPECT_EQ(fs::path(*(at + 1)), fs::absolute(priors / "tiny"));
  // A root without this scene's folder: no --priors, and the log says why.
  fs::create_directories(dir_->path() / "empty_priors");
  ASSERT_EQ(
      RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                    "' --priors '" + (dir_->path() / "empty_priors").string() +
                    "' --out '" + sweep.string() + "2'",
                log),
      0)
      << Slurp(log);
  const auto without = ReadJson(fs::path(sweep.string() + "2") /
                                "manifest.json")["entries"][0]["command"]
                           .get<std::vector<std::string>>();
  EXPECT_EQ(std::find(without.begin(), without.end(), "--priors"),
            without.end());
  EXPECT_NE(Slurp(log).find("without learned priors"), std::string::npos)
      << Slurp(log);
}

TEST_F(SweepTest, BadRequestsNameWhatIsWrong) {
  const fs::path log = dir_->path() / "bad.log";
  EXPECT_EQ(RunPano4d("sweep plan --root '" + (dir_->path() / "root").string() +
                          "' --configs default,fancy --out '" +
                          (dir_->path() / "bad").string() + "'",
                      log),
            1);
  EXPECT_NE(Slurp(log).find("fancy"), std::string::npos) << Slurp(log);
  EXPECT_NE(Slurp(log).find("no-expansion"), std::string::npos) << Slurp(log);
  EXPECT_THROW(SweepTaskIndex(-1, 4), Error);  // no index, no array task
  EXPECT_THROW(SweepTaskIndex(4, 4), Error);
  EXPECT_EQ(SweepTaskIndex(3, 4), 3);
  setenv("JOB_COMPLETION_INDEX", "2", 1);
  EXPECT_EQ(SweepTaskIndex(-1, 4), 2);
  unsetenv("JOB_COMPLETION_INDEX");
}

}  // namespace
}  // namespace pano4d
