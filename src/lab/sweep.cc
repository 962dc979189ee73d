#include "src/lab/sweep.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "evaluation/evaluate.h"
#include "src/core/csv.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/log.h"
#include "src/core/progress.h"
#include "src/core/stop_signal.h"
#include "src/core/strings.h"
#include "src/core/subprocess.h"
#include "src/core/workspace.h"
#include "src/core/workspace_lock.h"
#include "src/lab/bench.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

constexpr const char* kSweepFormat = "pano4d-sweep";
// Version 2: an entry's "command" holds pano4d's arguments; version 1
// named the program too, and a manifest passed between people must not
// choose what runs.
constexpr int kSweepVersion = 2;

// The flags `sweep plan` writes into an entry's `run` command, with
// whether each takes a value: a manifest may change their values (paths,
// iterations) but run nothing else, and no flag that starts a program
// (--prior-cmd).
const std::map<std::string, bool>& SweepRunFlags() {
  static const std::map<std::string, bool> kFlags = {
      {"--dataset", true},
      {"--workspace", true},
      {"--eval", false},
      {"--factor", true},
      {"--iterations", true},
      {"--converge-on", true},
      {"--lpips-weights", true},
      {"--priors", true},
      {"--seed", true},
      {"--deterministic", false},
      {"--no-expansion", false},
      {"--planar-expansion", false},
      {"--alpha", true},
      {"--one-step-expansion", false},
      {"--no-gaussian-refinement", false},
      {"--no-motion", false}};
  return kFlags;
}

// Throws an Error naming the manifest, the entry and the field unless
// `entry` is what `sweep plan` writes at position `position`.
void CheckSweepEntry(const Json& entry, std::size_t position,
                     const std::string& file) {
  const std::string at = "entries[" + std::to_string(position) + "]";
  if (!entry.is_object())
    throw Error(file, at, JsonValueForMessage(entry), "is not an object");
  const std::string source = file + ": " + at;
  if (GetJson<int>(entry, "index", source) != static_cast<int>(position)) {
    throw Error(file, at + ".index", entry["index"].dump(),
                "differs from the entry's position " +
                    std::to_string(position) +
                    " (entries are numbered 0, 1, "
                    "...; plan the sweep again)");
  }
  for (const char* key : {"scene", "suite", "config", "workspace"})
    GetJson<std::string>(entry, key, source);
  GetJson<int>(entry, "seed", source);
  const Json command = GetJson<Json>(entry, "command", source);
  if (!command.is_array() || command.empty() || command[0] != "run") {
    throw Error(file, at + ".command", JsonValueForMessage(command),
                "must be pano4d's arguments, starting with \"run\"");
  }
  std::string workspace;
  for (std::size_t i = 1; i < command.size(); ++i) {
    if (!command[i].is_string())
      throw Error(file, at + ".command", command[i].dump(), "is not a string");
    const std::string flag = command[i];
    const auto known = SweepRunFlags().find(flag);
    if (known == SweepRunFlags().end()) {
      throw Error(file, at + ".command", flag,
                  "is not a flag `sweep plan` writes; a manifest runs "
                  "`pano4d run` with its own flags only");
    }
    if (!known->second) continue;
    if (++i >= command.size() || !command[i].is_string())
      throw Error(file, at + ".command", flag, "has no value");
    if (flag == "--workspace") workspace = command[i];
  }
  if (workspace != entry["workspace"].get<std::string>()) {
    throw Error(
        file, at + ".command", "--workspace " + workspace,
        "differs from the entry's workspace " + entry["workspace"].dump());
  }
}

fs::path ThisExecutable(const fs::path& given) {
  return given.empty() ? fs::read_symlink("/proc/self/exe") : given;
}

fs::path StatusPath(const fs::path& sweep, int index) {
  return sweep / "status" / (std::to_string(index) + ".json");
}

// Throws an Error naming the file and the key unless each key of a status
// that is there has the type `sweep run` writes.
void CheckStatus(const Json& s, const std::string& file) {
  if (!s.is_object())
    throw Error(file, "", JsonValueForMessage(s), "is not an object");
  const auto check = [&](const char* key, bool ok) {
    if (s.contains(key) && !ok)
      throw Error(file, key, JsonValueForMessage(s[key]), "has the wrong type");
  };
  check("index", s.value("index", Json()).is_number_integer());
  check("seed", s.value("seed", Json()).is_number_integer());
  check("attempts", s.value("attempts", Json()).is_number_integer());
  for (const char* key : {"status", "error", "scene", "config", "host"})
    check(key, s.value(key, Json()).is_string());
  for (const char* key : {"seconds", "peak_memory_mib"})
    check(key, s.value(key, Json()).is_number());
  check("command", s.value("command", Json()).is_array());
  check("metrics", s.value("metrics", Json()).is_object());
  if (s.contains("metrics")) {
    for (const auto& [key, value] : s["metrics"].items())
      if (!value.is_number() && !value.is_null())
        throw Error(file, "metrics." + key, JsonValueForMessage(value),
                    "is not a number");
  }
}

// The status of entry `index`, or null when there is none or it is not
// one `sweep run` wrote (a hand edit; torn writes cannot happen).
Json ReadStatus(const fs::path& sweep, int index) {
  const fs::path path = StatusPath(sweep, index);
  if (!fs::exists(path)) return Json();
  try {
    Json status = ReadJson(path);
    CheckStatus(status, path.string());
    return status;
  } catch (const Error& e) {
    PANO4D_LOG(kWarning) << "sweep: " << e.what() << "; taken as no status";
    return Json();
  }
}

std::string Hostname() {
  char name[256] = {};
  gethostname(name, sizeof(name) - 1);
  return name;
}

}  // namespace

const std::map<std::string, std::vector<std::string>>& SweepConfigs() {
  static const std::map<std::string, std::vector<std::string>> kConfigs = {
      {"default", {}},
      {"no-expansion", {"--no-expansion"}},
      // The planar ablation moves cameras by tan(angle): 6 steps of 14.8
      // degrees keep the total below its 89 (as in docs/experiments/
      // 2026-11-22-expansion-ablation-2000.md).
      {"planar", {"--planar-expansion", "--alpha", "14.8"}},
      {"one-step", {"--one-step-expansion"}},
      {"no-refinement", {"--no-gaussian-refinement"}},
      {"no-motion", {"--no-motion"}},
  };
  return kConfigs;
}

Json PlanSweep(const SweepPlanOptions& o) {
  if (o.seeds.empty()) throw Error("--seeds", "", "", "give at least one seed");
  for (const std::string& c : o.configs) {
    if (!SweepConfigs().count(c)) {
      std::string known;
      for (const auto& [name, flags] : SweepConfigs())
        known += (known.empty() ? "" : ", ") + name;
      throw Error("--configs", "", c, "is not a configuration; use " + known);
    }
  }
  const std::vector<BenchScene> scenes =
      FindBenchScenes(o.root, o.suite, o.scenes);
  const fs::path executable = ThisExecutable(o.executable);
  const fs::path out = fs::absolute(o.out);
  Json entries = Json::array();
  for (const BenchScene& scene : scenes) {
    for (const std::string& config : o.configs) {
      for (const int seed : o.seeds) {
        const fs::path ws = out / "ws" / scene.name() /
                            (config + "_seed" + std::to_string(seed));
        std::vector<std::string> command = BenchRunCommand(
            executable, scene, ws, o.iterations, o.lpips_weights, o.priors);
        command.erase(command.begin());  // pano4d's arguments only
        command.insert(command.end(), {"--seed", std::to_string(seed)});
        if (o.deterministic) command.push_back("--deterministic");
        for (const std::string& flag : SweepConfigs().at(config))
          command.push_back(flag);
        entries.push_back({{"index", entries.size()},
                           {"scene", scene.name()},
                           {"suite", scene.suite},
                           {"seed", seed},
                           {"config", config},
                           {"workspace", ws.string()},
                           {"command", command}});
      }
    }
  }
  const Json manifest = {{"format", kSweepFormat},
                         {"version", kSweepVersion},
                         {"root", fs::absolute(o.root).string()},
                         {"suite", o.suite},
                         {"seeds", o.seeds},
                         {"configs", o.configs},
                         {"entries", entries}};
  EnsureDirectory(out);
  WriteJson(out / "manifest.json", manifest);
  return manifest;
}

Json ReadSweepManifest(const fs::path& sweep) {
  const fs::path path = sweep / "manifest.json";
  if (!fs::exists(path)) {
    throw Error::In(path.string(),
                    "missing: make it with `pano4d sweep plan --out " +
                        sweep.string() + "`");
  }
  const std::string file = path.string();
  const Json m = ReadJson(path);
  if (GetJson<std::string>(m, "format", file) != kSweepFormat)
    throw Error(file, "format", m["format"].dump(),
                std::string("expected ") + kSweepFormat);
  if (GetJson<int>(m, "version", file) != kSweepVersion) {
    throw Error(file, "version", m["version"].dump(),
                "this pano4d reads version " + std::to_string(kSweepVersion) +
                    " (entries hold pano4d's arguments, not a program); "
                    "plan the sweep again with `pano4d sweep plan`");
  }
  const Json entries = GetJson<Json>(m, "entries", file);
  if (!entries.is_array())
    throw Error(file, "entries", JsonValueForMessage(entries),
                "is not an array");
  for (std::size_t i = 0; i < entries.size(); ++i)
    CheckSweepEntry(entries[i], i, file);
  return m;
}

int SweepTaskIndex(int index, std::size_t entries) {
  std::string from = "--index";
  if (index < 0) {
    for (const char* name : {"SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"}) {
      const char* value = std::getenv(name);
      if (value == nullptr || *value == '\0') continue;
      char* end = nullptr;
      const long v = std::strtol(value, &end, 10);
      if (*end != '\0' || v < 0)
        throw Error(std::string("$") + name, "", value, "is not an index");
      index = static_cast<int>(v);
      from = std::string("$") + name;
      break;
    }
  }
  if (index < 0) {
    throw Error::In("sweep run",
                    "no entry index: give --index I, or run as a Slurm "
                    "array task ($SLURM_ARRAY_TASK_ID) or a Kubernetes "
                    "Indexed Job ($JOB_COMPLETION_INDEX)");
  }
  if (entries == 0)
    throw Error(from, "", std::to_string(index), "the manifest has no entries");
  if (static_cast<std::size_t>(index) >= entries) {
    throw Error(from, "", std::to_string(index),
                "the manifest has entries 0 to " + std::to_string(entries - 1));
  }
  return index;
}

SweepOutcome RunSweepEntry(const fs::path& sweep, int index,
                           const fs::path& executable) {
  const Json manifest = ReadSweepManifest(sweep);
  const Json& entry =
      manifest["entries"].at(SweepTaskIndex(index, manifest["entries"].size()));
  const std::vector<std::string> command =
      entry["command"].get<std::vector<std::string>>();
  std::vector<std::string> argv = {ThisExecutable(executable).string()};
  argv.insert(argv.end(), command.begin(), command.end());
  // One process per entry: a second `sweep run` of it is refused, naming
  // the first, before it touches the status.
  const FolderLock lock(
      sweep / "status" / (std::to_string(entry["index"].get<int>()) + ".lock"),
      FolderLock::Mode::kExclusive, ThisCommandLine());
  Json status = ReadStatus(sweep, index);
  if (status.is_object() && status.value("status", "") == "done" &&
      status.value("command", std::vector<std::string>{}) == command) {
    PANO4D_LOG(kInfo) << "sweep: entry " << index << " finished earlier";
    return SweepOutcome::kDoneEarlier;
  }
  const double earlier = status.is_object() ? status.value("seconds", 0.0) : 0;
  const int attempts =
      (status.is_object() ? status.value("attempts", 0) : 0) + 1;
  status = {{"index", index},        {"scene", entry["scene"]},
            {"seed", entry["seed"]}, {"config", entry["config"]},
            {"command", command},    {"status", "running"},
            {"host", Hostname()},    {"attempts", attempts},
            {"seconds", earlier}};
  if (const char* job = std::getenv("SLURM_JOB_ID")) status["slurm_job"] = job;
  WriteJson(StatusPath(sweep, index), status);
  const fs::path log = sweep / "logs" / (std::to_string(index) + ".log");
  EnsureDirectory(log.parent_path());
  PANO4D_LOG(kInfo) << "sweep: entry " << index << " (" << entry["scene"]
                    << ", " << entry["config"] << ", seed " << entry["seed"]
                    << "), log " << log.string();
  std::optional<SignalsForwarded> forwarded;
  forwarded.emplace();  // ends this process after the child, if signalled
  ProcessOptions forward;
  forward.forward_signals = true;
  const ProcessResult r = RunProcess(argv, log, forward);
  const int signalled = SignalsForwarded::Received();
  status["seconds"] = earlier + r.seconds;
  status["peak_memory_mib"] =
      std::max(r.peak_memory_mib, status.value("peak_memory_mib", 0.0));
  SweepOutcome outcome = SweepOutcome::kDone;
  if (r.exit_code == kStoppedExitStatus || (!r.ok() && StopRequested())) {
    status["status"] = "stopped";
    status["error"] = "stopped on request; the next attempt resumes it";
    outcome = SweepOutcome::kStopped;
  } else if (!r.ok() && signalled != 0) {
    status["status"] = "stopped";
    status["error"] = "stopped by signal " + std::to_string(signalled) +
                      "; the next attempt resumes it";
    outcome = SweepOutcome::kStopped;
  } else if (!r.ok()) {
    status["status"] = "failed";
    status["error"] = ProcessFailure(r, log);
    outcome = SweepOutcome::kFailed;
  } else {
    const Workspace ws(entry["workspace"].get<std::string>());
    try {
      const Json m = ReadJson(ws.metrics_json());
      status["metrics"] = GetJson<Json>(m, "mean", ws.metrics_json().string());
      status["status"] = "done";
      status["error"] = "";
    } catch (const Error& e) {
      status["status"] = "failed";
      status["error"] = e.what();
      outcome = SweepOutcome::kFailed;
    }
  }
  WriteJson(StatusPath(sweep, index), status);
  forwarded.reset();  // a signal that arrived ends this process now
  return outcome;
}

int RunSweepLocal(const fs::path& sweep, int jobs, const fs::path& exe) {
  const Json manifest = ReadSweepManifest(sweep);
  const int n = static_cast<int>(manifest["entries"].size());
  const fs::path executable = ThisExecutable(exe);
  std::atomic<int> next{0}, not_done{0};
  ProgressBar bar("sweep local", n);
  std::mutex bar_mutex;
  // SIGINT, SIGTERM, SIGHUP and the stop signal reach the running entries
  // (which save their state), no new entry starts, and this process ends
  // once they have.
  const SignalsForwarded forwarded;
  ProcessOptions forward;
  forward.forward_signals = true;
  std::vector<std::thread> workers;
  for (int w = 0; w < std::max(1, jobs); ++w) {
    workers.emplace_back([&] {
      for (int i; (i = next++) < n;) {
        if (StopRequested() || SignalsForwarded::Received() != 0) {
          ++not_done;
          continue;
        }
        const fs::path log =
            sweep / "logs" / (std::to_string(i) + ".local.log");
        EnsureDirectory(log.parent_path());
        const ProcessResult r =
            RunProcess({executable.string(), "sweep", "run", sweep.string(),
                        "--index", std::to_string(i)},
                       log, forward);
        if (!r.ok()) ++not_done;
        const std::lock_guard<std::mutex> lock(bar_mutex);
        bar.Add();
      }
    });
  }
  for (std::thread& t : workers) t.join();
  bar.Finish();
  return not_done;
}

fs::path WriteSbatchScript(const fs::path& sweep, const SbatchOptions& o) {
  const Json manifest = ReadSweepManifest(sweep);
  const std::size_t n = manifest["entries"].size();
  const fs::path dir = fs::absolute(sweep);
  const fs::path executable = ThisExecutable(o.executable);
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# pano4d sweep: one array task per manifest entry (" << n
    << " entries). Each task runs `pano4d sweep run`, which skips an entry\n"
    << "# that finished and resumes one that was stopped; SIGUSR1 before the\n"
    << "# time limit lets the running fit checkpoint (exit 75), and the task\n"
    << "# is requeued.\n"
    << "#SBATCH --job-name=pano4d-sweep\n"
    << "#SBATCH --array=0-" << n - 1
    << (o.max_parallel > 0 ? "%" + std::to_string(o.max_parallel) : "") << "\n"
    << "#SBATCH --requeue\n"
    << "#SBATCH --open-mode=append\n"
    << "#SBATCH --output=" << (dir / "logs" / "slurm_%A_%a.out").string()
    << "\n"
    << "#SBATCH --signal=B:USR1@" << o.signal_seconds << "\n"
    << "#SBATCH --cpus-per-task=" << o.cpus << "\n";
  if (!o.partition.empty()) s << "#SBATCH --partition=" << o.partition << "\n";
  if (!o.mem.empty()) s << "#SBATCH --mem=" << o.mem << "\n";
  if (!o.time.empty()) s << "#SBATCH --time=" << o.time << "\n";
  s << "export OMP_NUM_THREADS=${SLURM_CPUS_PER_TASK:-" << o.cpus << "}\n"
    << "'" << executable.string() << "' sweep run '" << dir.string()
    << "' --index \"$SLURM_ARRAY_TASK_ID\" &\n"
    << "child=$!\n"
    << "# The entry's pano4d run is the child's child: both hear the signal.\n"
    << "trap 'pkill -USR1 -P \"$child\"; kill -USR1 \"$child\"' USR1\n"
    << "wait \"$child\"; status=$?\n"
    << "while kill -0 \"$child\" 2>/dev/null; do wait \"$child\"; "
       "status=$?; done\n"
    << "if [ \"$status\" -eq " << kStoppedExitStatus << " ]; then\n"
    << "  scontrol requeue \"${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID}\"\n"
    << "fi\n"
    << "exit \"$status\"\n";
  const fs::path script = dir / "sweep.sbatch";
  WriteFileAtomically(script, s.str());
  fs::permissions(script, fs::perms::owner_exec, fs::perm_options::add);
  EnsureDirectory(dir / "logs");
  return script;
}

std::string SubmitSbatch(const fs::path& script) {
  const auto sbatch = FindOnPath("sbatch");
  if (!sbatch) {
    throw Error::In("sbatch",
                    "not found on PATH: submit from a Slurm login node, or "
                    "run `pano4d sweep local` here");
  }
  const fs::path log = script.parent_path() / "logs" / "sbatch.log";
  const ProcessResult r =
      RunProcess({sbatch->string(), "--parsable", script.string()}, log);
  if (!r.ok())
    throw Error("sbatch", script.string(), "",
                "failed: " + ProcessFailure(r, log));
  const std::string last = LastLines(log, 1);
  return last.substr(0, last.find_first_of(";\n"));
}

namespace {

// An entry's result as its status file says it.
struct EntryResult {
  std::string status;  // done, failed, stopped, running, missing, stale
  std::string error;
  MetricRow values;
  double seconds = 0, memory = 0;
  int attempts = 0;
};

EntryResult ReadEntryResult(const fs::path& sweep, const Json& entry) {
  const int index = entry["index"].get<int>();
  Json s = ReadStatus(sweep, index);
  std::string stale;
  if (s.is_object() && (s.value("index", -1) != index ||
                        s.value("command", Json()) != entry["command"])) {
    // Written for another plan of this folder: not this entry's result.
    s = Json();
    stale =
        "its status is of an earlier plan of this folder; `sweep run` "
        "runs it again";
  }
  EntryResult r;
  r.status = s.is_object() ? s.value("status", "missing")
                           : (stale.empty() ? "missing" : "stale");
  r.error = s.is_object() ? s.value("error", "") : stale;
  if (s.is_object() && s.contains("metrics"))
    r.values = MetricRowFromJson(s["metrics"]);
  r.seconds = s.is_object() ? s.value("seconds", 0.0) : 0.0;
  r.memory = s.is_object() ? s.value("peak_memory_mib", 0.0) : 0;
  r.attempts = s.is_object() ? s.value("attempts", 0) : 0;
  return r;
}

std::string EntryCsvRow(const Json& e, const EntryResult& r) {
  std::vector<std::string> fields = {std::to_string(e["index"].get<int>()),
                                     e["scene"].get<std::string>(),
                                     e["suite"].get<std::string>(),
                                     e["config"].get<std::string>(),
                                     std::to_string(e["seed"].get<int>()),
                                     r.status,
                                     r.error};
  for (std::size_t k = 0; k < kNumMetrics; ++k)
    fields.push_back(r.values[k] ? StringPrintf("%.6f", *r.values[k]) : "");
  fields.push_back(StringPrintf("%.1f", r.seconds));
  fields.push_back(StringPrintf("%.0f", r.memory));
  fields.push_back(std::to_string(r.attempts));
  return CsvRow(fields);
}

// A scene and configuration's entries: planned, and the finished ones'.
struct ConfigRuns {
  int planned = 0;
  std::vector<MetricRow> done;
  std::vector<double> seconds, memory;
};

// The mean over `rows` of each metric every row has, and its spread
// (population standard deviation).
void MeanAndSpread(const std::vector<MetricRow>& rows, MetricRow* mean,
                   MetricRow* spread) {
  for (std::size_t k = 0; k < kNumMetrics && !rows.empty(); ++k) {
    double sum = 0, squares = 0;
    bool all = true;
    for (const MetricRow& r : rows) {
      if (!r[k]) all = false;
      if (r[k]) sum += *r[k], squares += *r[k] * *r[k];
    }
    if (!all) continue;
    (*mean)[k] = sum / rows.size();
    (*spread)[k] = std::sqrt(
        std::max(0.0, squares / rows.size() - *(*mean)[k] * *(*mean)[k]));
  }
}

// bench datasets' table, per scene and configuration (in `order`), each
// scene followed by its published rows.
void WriteConfigTable(
    const std::vector<std::pair<std::string, std::string>>& order,
    std::map<std::pair<std::string, std::string>, ConfigRuns>& runs,
    std::map<std::string, std::string>& suite_of, std::ostream& md) {
  std::map<std::string, Json> benchmarks;
  for (std::size_t i = 0; i < order.size(); ++i) {
    const auto& key = order[i];
    const std::string& suite = suite_of[key.first];
    const ConfigRuns& r = runs[key];
    MetricRow mean, spread;
    MeanAndSpread(r.done, &mean, &spread);
    double secs = 0, memory = 0;
    for (const double v : r.seconds) secs += v;
    for (const double v : r.memory) memory = std::max(memory, v);
    const std::string label =
        StringPrintf("pano4d %s, mean of %zu of %d seeds", key.second.c_str(),
                     r.done.size(), r.planned);
    md << BenchMarkdownRow(
        key.first, suite, label, mean,
        r.done.empty() ? "-" : StringPrintf("%.0f", secs / r.done.size()),
        r.done.empty() ? "-" : StringPrintf("%.0f", memory));
    md << BenchMarkdownRow(key.first, suite,
                           "pano4d " + key.second + ", spread", spread, "", "");
    // After a scene's last configuration, its published rows.
    if (i + 1 < order.size() && order[i + 1].first == key.first) continue;
    if (!benchmarks.count(suite)) benchmarks[suite] = SuiteBenchmarkMeta(suite);
    for (const PublishedRow& p : PublishedRows(benchmarks[suite], key.first)) {
      if (p.mean) continue;
      md << BenchMarkdownRow(key.first, suite, p.method + " (" + p.source + ")",
                             p.values, "", "");
    }
  }
}

}  // namespace

SweepTable CollectSweep(const fs::path& sweep) {
  const Json manifest = ReadSweepManifest(sweep);
  SweepTable t;
  std::ostringstream md, csv;
  const std::string metric_head =
      " PSNR | SSIM | LPIPS | mPSNR | mSSIM | mLPIPS | uPSNR | uSSIM | "
      "uLPIPS |";
  const std::string metric_rule = "---|---|---|---|---|---|---|---|---|";
  md << "# pano4d sweep: " << fs::absolute(sweep).string() << "\n\n"
     << "## Entries\n\n| # | Scene | Config | Seed | Status |" << metric_head
     << " Seconds | Peak MiB |\n|---|---|---|---|---|" << metric_rule
     << "---|---|\n";
  csv << "index,scene,suite,config,seed,status,error";
  for (const char* key : kMetricKeys) csv << "," << key;
  csv << ",seconds,peak_memory_mib,attempts\n";
  std::map<std::pair<std::string, std::string>, ConfigRuns> runs;
  std::map<std::string, std::string> suite_of;
  std::vector<std::pair<std::string, std::string>> order;
  for (const Json& e : manifest["entries"]) {
    ++t.entries;
    const int index = e["index"].get<int>();
    const std::string scene = e["scene"], config = e["config"];
    suite_of[scene] = e["suite"];
    const auto key = std::make_pair(scene, config);
    ConfigRuns& r = runs[key];
    if (r.planned++ == 0) order.push_back(key);
    const EntryResult result = ReadEntryResult(sweep, e);
    if (result.status == "done") {
      ++t.done;
      r.done.push_back(result.values);
      r.seconds.push_back(result.seconds);
      r.memory.push_back(result.memory);
    } else {
      result.status == "missing" || result.status == "stale" ? ++t.missing
                                                             : ++t.failed;
      t.problems.push_back(StringPrintf(
          "%d %s %s seed %d: %s%s", index, scene.c_str(), config.c_str(),
          e["seed"].get<int>(), result.status.c_str(),
          result.error.empty() ? "" : (": " + result.error).c_str()));
    }
    md << "| " << index << " | " << scene << " | " << config << " | "
       << e["seed"].get<int>() << " | " << result.status << " |";
    for (std::size_t k = 0; k < kBenchTableMetrics; ++k)
      md << " " << BenchCell(result.values[k], k) << " |";
    md << " " << StringPrintf("%.0f", result.seconds) << " | "
       << StringPrintf("%.0f", result.memory) << " |\n";
    csv << EntryCsvRow(e, result);
  }

  md << "\n## Per scene and configuration\n\nbench datasets' table: per "
        "configuration the mean over the seeds that finished and their "
        "spread (population standard deviation); seconds per entry, the "
        "largest peak memory. Published rows follow each scene.\n\n"
     << kBenchTableHead;
  WriteConfigTable(order, runs, suite_of, md);
  md << "\n## Not done\n\n";
  if (t.problems.empty()) md << "Every entry finished.\n";
  for (const std::string& p : t.problems) md << "- " << p << "\n";
  WriteFileAtomically(sweep / "sweep.md", md.str());
  WriteFileAtomically(sweep / "sweep.csv", csv.str());
  t.markdown = md.str();
  return t;
}

}  // namespace pano4d
