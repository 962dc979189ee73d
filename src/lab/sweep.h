#pragma once

// Benchmark sweeps: scenes x seeds x configurations, each entry one
// resumable `pano4d run --eval` in a workspace of its own, run as a Slurm
// job-array task, a Kubernetes Indexed Job's pod, or by a local process
// pool, and collected into one table. Built on `bench datasets`' scene
// discovery and run command (bench.h).
//
//   SWEEP/manifest.json       {"format": "pano4d-sweep", "version": 2,
//                             "entries": [{"index", "scene", "suite",
//                             "seed", "config", "workspace", "command"}]};
//                             "command" is pano4d's arguments ("run",
//                             then the flags `sweep plan` writes), run by
//                             this pano4d binary
//   SWEEP/status/<i>.json     per entry: "status" (running, done, failed,
//                             stopped), "error", "seconds" (all attempts),
//                             "attempts", "peak_memory_mib", "metrics"
//   SWEEP/logs/<i>.log        the entry's run output
//   SWEEP/sweep.sbatch        `sweep sbatch`'s job array
//   SWEEP/sweep.md, .csv      `sweep collect`'s tables

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "src/core/json.h"

namespace pano4d {

// The configurations a sweep can compare: name -> `pano4d run` flags.
const std::map<std::string, std::vector<std::string>>& SweepConfigs();

struct SweepPlanOptions {
  std::filesystem::path root;       // scene folders, as bench datasets
  std::string suite;                // empty: every suite
  std::vector<std::string> scenes;  // empty: every scene of the suite
  std::vector<int> seeds = {0};
  std::vector<std::string> configs = {"default"};
  int iterations = 0;          // 0: run's default schedule
  bool deterministic = false;  // run --deterministic
  std::filesystem::path lpips_weights;
  std::filesystem::path priors;      // as BenchDatasetsOptions::priors
  std::filesystem::path out;         // SWEEP
  std::filesystem::path executable;  // pano4d; empty: this binary
};

// Writes SWEEP/manifest.json (atomically) and returns it. Throws
// pano4d::Error for an unknown configuration (naming the known ones), no
// seed, or what FindBenchScenes refuses.
Json PlanSweep(const SweepPlanOptions& options);

// The manifest of SWEEP, checked against the schema above; throws
// pano4d::Error naming the file and the field when it is missing, not a
// sweep manifest of this version, or an entry lacks a key, is out of
// order, or its command is not `run` with `sweep plan`'s flags.
Json ReadSweepManifest(const std::filesystem::path& sweep);

// The entry index a task runs: `index` when it is >= 0, else
// $SLURM_ARRAY_TASK_ID, else $JOB_COMPLETION_INDEX. Throws pano4d::Error
// when none is set or the index is outside the manifest.
int SweepTaskIndex(int index, std::size_t entries);

enum class SweepOutcome { kDone, kDoneEarlier, kFailed, kStopped };

// Runs entry `index` of SWEEP (as SweepTaskIndex) with `executable`
// (empty: this binary) unless its status says it finished with the same
// command; writes its status first as running, then as it ended. A run
// stopped on request (stop_signal.h) is "stopped": its checkpoint is kept
// and the next attempt resumes it.
SweepOutcome RunSweepEntry(const std::filesystem::path& sweep, int index,
                           const std::filesystem::path& executable = {});

// Every entry on this machine, `jobs` at a time, each as a child `pano4d
// sweep run SWEEP --index I`; returns the entries that did not end done.
int RunSweepLocal(const std::filesystem::path& sweep, int jobs,
                  const std::filesystem::path& executable = {});

struct SbatchOptions {
  std::string partition;     // empty: the cluster's default
  int cpus = 2;              // per task
  std::string mem;           // e.g. "8G"; empty: the partition's default
  std::string time;          // e.g. "02:00:00"; empty: the default
  int max_parallel = 0;      // tasks at once; 0: no limit
  int signal_seconds = 120;  // USR1 this long before the time limit
  std::filesystem::path executable;  // empty: this binary
};

// Writes SWEEP/sweep.sbatch: `--array=0-(N-1)[%K]`, `--requeue`, and
// SIGUSR1 signal_seconds before the time limit, which the script passes to
// the running entry (fit checkpoints and stops, exit 75) and then requeues
// the task. Returns the script's path.
std::filesystem::path WriteSbatchScript(const std::filesystem::path& sweep,
                                        const SbatchOptions& options);

// `sbatch --parsable SCRIPT`: the job id. Throws pano4d::Error with
// sbatch's output when it fails or is not installed.
std::string SubmitSbatch(const std::filesystem::path& script);

struct SweepTable {
  std::string markdown;
  int entries = 0, done = 0, failed = 0, missing = 0;
  std::vector<std::string> problems;  // "<index> <scene> ...: <error>"
};

// Writes SWEEP/sweep.md and SWEEP/sweep.csv: one row per entry, then bench
// datasets' table with, per scene and configuration, the mean and the
// spread (population standard deviation) over the seeds that finished,
// beside the published rows of the scene's benchmark; failed, stopped and
// missing entries are listed with their errors, not dropped; a status
// written for another plan of the folder (another command or index) is
// "stale", not a result.
SweepTable CollectSweep(const std::filesystem::path& sweep);

}  // namespace pano4d
