// `pano4d bench datasets`: every scene of a benchmark root through `pano4d
// run --eval`, in a table beside the published rows (bench.h).
#include <algorithm>
#include <cstdio>
#include <map>
#include <sstream>

#include "evaluation/evaluate.h"
#include "src/core/csv.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/strings.h"
#include "src/core/subprocess.h"
#include "src/core/workspace.h"
#include "src/datasets/dataset.h"
#include "src/datasets/dycheck_dataset.h"
#include "src/datasets/kubric_dataset.h"
#include "src/datasets/nvidia_dataset.h"
#include "src/datasets/priors.h"
#include "src/lab/bench.h"
#include "src/pipeline/eval.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

struct Entry {
  std::string scene, suite;
  std::string status;  // "done" or "failed"
  std::string error;
  double seconds = 0, peak_memory_mib = 0;
  bool resumed = false;
  MetricRow values;
  std::vector<std::string> command;

  nlohmann::json ToJson() const {
    const nlohmann::json metrics = MetricRowJson(values);
    return {{"scene", scene},     {"suite", suite},
            {"status", status},   {"error", error},
            {"seconds", seconds}, {"peak_memory_mib", peak_memory_mib},
            {"metrics", metrics}, {"command", command}};
  }
};

}  // namespace

Json SuiteBenchmarkMeta(const std::string& suite) {
  // The benchmark file's kind for a suite (synthetic scenes have none).
  if (suite == "synth") return Json();
  return BenchmarkMeta(DatasetsMetaDir(),
                       suite == "kubric" ? "kubric4d" : suite);
}

std::vector<std::string> BenchRunCommand(const fs::path& executable,
                                         const BenchScene& scene,
                                         const fs::path& workspace,
                                         int iterations,
                                         const fs::path& lpips_weights,
                                         const fs::path& priors_root) {
  // The protocol's factor, written out so that the command says it.
  const int factor = LoadDataset(scene.dir, kProtocolFactor).factor;
  std::vector<std::string> command = {executable.string(),
                                      "run",
                                      "--dataset",
                                      fs::absolute(scene.dir).string(),
                                      "--workspace",
                                      fs::absolute(workspace).string(),
                                      "--eval",
                                      "--factor",
                                      std::to_string(factor)};
  if (iterations > 0) {
    command.push_back("--iterations");
    command.push_back(std::to_string(iterations));
  } else {
    command.push_back("--converge-on");
    command.push_back("train");
  }
  if (!lpips_weights.empty()) {
    command.push_back("--lpips-weights");
    command.push_back(fs::absolute(lpips_weights).string());
  }
  if (!priors_root.empty()) {
    const fs::path priors = priors_root / scene.dir.filename();
    try {
      ScanPriors(priors);
      command.push_back("--priors");
      command.push_back(fs::absolute(priors).string());
    } catch (const Error& e) {
      PANO4D_LOG(kInfo) << "bench: " << scene.dir.filename().string()
                        << " runs without learned priors: " << e.what();
    }
  }
  return command;
}

namespace {

Entry RunScene(const fs::path& dir, const std::string& suite,
               const BenchDatasetsOptions& o, const fs::path& executable) {
  Entry e;
  e.scene = dir.filename().string();
  e.suite = suite;
  const Workspace ws(o.workspace / e.scene);
  try {
    e.command = BenchRunCommand(executable, {dir, suite}, ws.root(),
                                o.iterations, o.lpips_weights, o.priors);
  } catch (const Error& error) {
    e.status = "failed";
    e.error = error.what();
    return e;
  }
  const fs::path entry_file = ws.pano4d() / "bench_entry.json";
  nlohmann::json j;
  try {
    if (fs::exists(entry_file)) j = ReadJson(entry_file);
  } catch (const Error& error) {  // unreadable: run the scene again
    PANO4D_LOG(kWarning) << "bench datasets: " << error.what();
  }
  if (j.is_object()) {
    if (j.value("status", "") == "done" &&
        j.value("command", std::vector<std::string>{}) == e.command) {
      e.status = "done";
      e.resumed = true;
      e.seconds = j.value("seconds", 0.0);
      e.peak_memory_mib = j.value("peak_memory_mib", 0.0);
      e.values =
          MetricRowFromJson(j.value("metrics", nlohmann::json::object()));
      return e;
    }
  }
  const fs::path log = ws.pano4d() / "logs" / "bench_run.log";
  const ProcessResult r = RunProcess(e.command, log);
  e.seconds = r.seconds;
  e.peak_memory_mib = r.peak_memory_mib;
  if (!r.ok()) {
    e.status = "failed";
    e.error = ProcessFailure(r, log);
  } else {
    try {
      const nlohmann::json m = ReadJson(ws.metrics() / "metrics.json");
      e.values = MetricRowFromJson(GetJson<nlohmann::json>(
          m, "mean", (ws.metrics() / "metrics.json").string()));
      e.status = "done";
    } catch (const Error& error) {
      e.status = "failed";
      e.error = error.what();
    }
  }
  WriteJson(entry_file, e.ToJson());
  return e;
}

std::string TableCsvRow(const std::string& scene, const std::string& suite,
                        const std::string& method, const std::string& source,
                        const std::string& status, const std::string& error,
                        const MetricRow& values, const std::string& seconds,
                        const std::string& memory) {
  std::vector<std::string> fields = {scene,  suite,  method,
                                     source, status, error};
  for (std::size_t k = 0; k < kNumMetrics; ++k)
    fields.push_back(values[k] ? StringPrintf("%.6f", *values[k]) : "");
  fields.push_back(seconds);
  fields.push_back(memory);
  return CsvRow(fields);
}

}  // namespace

std::string SuiteOf(const fs::path& dir) {
  if (LooksLikeDyCheck(dir)) {
    const fs::path meta = dir / "synth.json";
    const bool synth = fs::exists(meta) &&
                       ReadJson(meta).value("generator", "") == "pano4d synth";
    return synth ? "synth" : "dycheck";
  }
  if (LooksLikeNvidia(dir)) return "nvidia";
  if (LooksLikeKubric4D(dir)) return "kubric";
  return "";
}

std::string BenchCell(const std::optional<double>& v, std::size_t key) {
  return v ? StringPrintf(MetricFormat(key), *v) : std::string("-");
}

std::string BenchMarkdownRow(const std::string& scene, const std::string& suite,
                             const std::string& method, const MetricRow& values,
                             const std::string& seconds,
                             const std::string& memory) {
  std::string row = "| " + scene + " | " + suite + " | " + method + " |";
  for (std::size_t k = 0; k < kBenchTableMetrics; ++k)
    row += " " + BenchCell(values[k], k) + " |";
  return row + " " + seconds + " | " + memory + " |\n";
}

std::vector<BenchScene> FindBenchScenes(const fs::path& root,
                                        const std::string& suite,
                                        const std::vector<std::string>& names) {
  if (!fs::is_directory(root))
    throw Error::In(root.string(), "is not a folder of scenes (--root)");
  if (!suite.empty() && std::find(kBenchSuites.begin(), kBenchSuites.end(),
                                  suite) == kBenchSuites.end()) {
    throw Error("--suite", "", suite, "use nvidia, dycheck, kubric or synth");
  }
  std::vector<BenchScene> scenes;
  std::vector<fs::path> dirs;
  for (const auto& entry : fs::directory_iterator(root))
    if (entry.is_directory()) dirs.push_back(entry.path());
  std::sort(dirs.begin(), dirs.end());
  constexpr const char* kNotAScene =
      "is not a scene in a layout pano4d reads (DyCheck's splits/ and "
      "camera/, Nvidia's poses_bounds.npy, Kubric-4D's metadata)";
  for (const fs::path& dir : dirs) {
    const std::string name = dir.filename().string();
    if (!names.empty() &&
        std::find(names.begin(), names.end(), name) == names.end())
      continue;
    const std::string found = SuiteOf(dir);
    if (found.empty()) {
      PANO4D_LOG(kWarning) << "bench: " << dir.string() << " left out: it "
                           << kNotAScene;
      continue;
    }
    if (!suite.empty() && found != suite) continue;
    scenes.push_back({dir, found});
  }
  for (const std::string& wanted : names) {
    if (std::none_of(scenes.begin(), scenes.end(), [&](const BenchScene& s) {
          return s.dir.filename() == wanted;
        })) {
      const fs::path dir = root / wanted;
      if (fs::is_directory(dir) && SuiteOf(dir).empty())
        throw Error(dir.string(), "--scenes", wanted, kNotAScene);
      throw Error(root.string(), "--scenes", wanted,
                  fs::is_directory(dir)
                      ? "is a scene of suite " + SuiteOf(dir) + ", not " + suite
                      : std::string("no scene folder of that name"));
    }
  }
  if (scenes.empty()) {
    throw Error::In(root.string(),
                    "holds no scene folder pano4d reads" +
                        (suite.empty() ? std::string() : " of suite " + suite));
  }
  return scenes;
}

namespace {

// Every scene through `pano4d run` (one workspace each, resumable).
std::vector<Entry> RunScenes(const BenchDatasetsOptions& o) {
  std::vector<std::pair<fs::path, std::string>> scenes;
  for (const BenchScene& scene : FindBenchScenes(o.root, o.suite, o.scenes))
    scenes.emplace_back(scene.dir, scene.suite);
  const fs::path executable =
      o.executable.empty() ? fs::read_symlink("/proc/self/exe") : o.executable;
  EnsureDirectory(o.workspace);
  std::vector<Entry> entries;
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    const auto& [dir, suite] = scenes[i];
    PANO4D_LOG(kInfo) << "bench datasets: [" << i + 1 << "/" << scenes.size()
                      << "] " << dir.filename().string() << " (" << suite
                      << ") ...";
    entries.push_back(RunScene(dir, suite, o, executable));
    const Entry& e = entries.back();
    PANO4D_LOG(kInfo) << "bench datasets: " << e.scene << ": "
                      << (e.resumed ? "complete from an earlier run" : e.status)
                      << (e.error.empty() ? "" : " (" + e.error + ")") << ", "
                      << e.seconds << " s";
  }
  return entries;
}

// Per scene pano4d's row, then the scene's published rows.
void WriteSceneRows(const std::vector<Entry>& entries,
                    std::map<std::string, nlohmann::json>* benchmarks,
                    std::ostream& md, std::ostream& csv) {
  for (const Entry& e : entries) {
    if (!benchmarks->count(e.suite))
      (*benchmarks)[e.suite] = SuiteBenchmarkMeta(e.suite);
    const std::string seconds = StringPrintf("%.0f", e.seconds);
    const std::string memory = StringPrintf("%.0f", e.peak_memory_mib);
    md << BenchMarkdownRow(
        e.scene, e.suite,
        e.status == "done" ? "pano4d" : "pano4d: " + e.status + ": " + e.error,
        e.values, seconds, memory);
    csv << TableCsvRow(e.scene, e.suite, "pano4d", "pano4d", e.status, e.error,
                       e.values, seconds, memory);
    for (const PublishedRow& p :
         PublishedRows((*benchmarks)[e.suite], e.scene)) {
      if (p.mean) continue;
      md << BenchMarkdownRow(e.scene, e.suite, p.method + " (" + p.source + ")",
                             p.values, "", "");
      csv << TableCsvRow(e.scene, e.suite, p.method, p.source, "published", "",
                         p.values, "", "");
    }
  }
}

// Means per suite: pano4d's over the scenes that finished here, the
// published means over each benchmark's own scene list.
void WriteSuiteMeans(const std::vector<Entry>& entries,
                     std::map<std::string, nlohmann::json>& benchmarks,
                     std::ostream& md, std::ostream& csv) {
  for (const std::string& suite : kBenchSuites) {
    std::vector<const Entry*> done;
    int total = 0;
    for (const Entry& e : entries) {
      if (e.suite != suite) continue;
      ++total;
      if (e.status == "done") done.push_back(&e);
    }
    if (total == 0) continue;
    MetricRow mean;
    for (std::size_t k = 0; k < kNumMetrics; ++k) {
      double sum = 0;
      int n = 0;
      for (const Entry* e : done)
        if (e->values[k]) sum += *e->values[k], ++n;
      if (n == static_cast<int>(done.size()) && n > 0) mean[k] = sum / n;
    }
    double seconds = 0, memory = 0;
    for (const Entry* e : done) {
      seconds += e->seconds;
      memory = std::max(memory, e->peak_memory_mib);
    }
    const std::string label =
        StringPrintf("mean (%zu of %d scenes)", done.size(), total);
    const std::string s =
        done.empty() ? "" : StringPrintf("%.0f", seconds / done.size());
    const std::string m = done.empty() ? "" : StringPrintf("%.0f", memory);
    md << BenchMarkdownRow("mean", suite, "pano4d, " + label, mean, s, m);
    csv << TableCsvRow("mean", suite, "pano4d", label, "mean", "", mean, s, m);
    for (const PublishedRow& p : PublishedRows(benchmarks[suite], "")) {
      if (!p.mean) continue;
      md << BenchMarkdownRow("mean", suite, p.method + " (" + p.source + ")",
                             p.values, "", "");
      csv << TableCsvRow("mean", suite, p.method, p.source, "published", "",
                         p.values, "", "");
    }
  }
}

}  // namespace

BenchResult RunBenchDatasets(const BenchDatasetsOptions& o) {
  const std::vector<Entry> entries = RunScenes(o);
  BenchResult result;
  std::ostringstream md, csv;
  md << "# pano4d bench datasets: " << o.root.string() << "\n\n"
     << "Each scene: `pano4d run --dataset <scene> --eval` at its protocol's "
        "factor"
     << (o.iterations > 0 ? ", " + std::to_string(o.iterations) + " iterations"
                          : std::string(", the default schedule with the "
                                        "convergence stop on the training "
                                        "frames' PSNR"))
     << "; seconds and peak memory of that run. Published rows follow each "
        "scene where a source gives per-scene numbers.\n\n";
  const std::string head = kBenchTableHead;
  md << head;
  csv << "scene,suite,method,source,status,error";
  for (const char* key : kMetricKeys) csv << "," << key;
  csv << ",seconds,peak_memory_mib\n";
  std::map<std::string, nlohmann::json> benchmarks;
  WriteSceneRows(entries, &benchmarks, md, csv);
  for (const Entry& e : entries) result.rows.push_back(e.ToJson());
  md << "\n## Means per suite\n\npano4d's mean is over the scenes of this run "
        "that finished; a published mean is over its benchmark's scenes "
        "(datasets_meta/), which may be more.\n\n"
     << head;
  WriteSuiteMeans(entries, benchmarks, md, csv);
  md << "\nSeconds of a mean row: per scene; peak memory: the largest.\n";
  WriteFileAtomically(o.workspace / "datasets.md", md.str());
  WriteFileAtomically(o.workspace / "datasets.csv", csv.str());
  result.table = md.str() + "\nwritten to " +
                 (o.workspace / "datasets.md").string() + " and datasets.csv\n";
  return result;
}

}  // namespace pano4d
