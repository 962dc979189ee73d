// `pano4d bench budget`: error against run time across budgets (bench.h).
// The synthetic scene is fitted at several iteration counts and
// resolutions; the final PSNR / mPSNR / uPSNR against the wall time of each
// fit go into a table and a plot per resolution, so that a user can choose
// a budget.
#include <algorithm>
#include <cstdio>
#include <optional>
#include <sstream>

#include "evaluation/plot.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/workspace.h"
#include "src/datasets/synth_generate.h"
#include "src/lab/bench.h"
#include "src/pipeline/depth.h"
#include "src/pipeline/fit.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// The paper's schedule, an expansion every 2000 of 10000 iterations, at
// every budget: five per run.
constexpr int kExpansionsPerRun = 5;

struct BudgetRow {
  int factor = 0;
  int iterations = 0;
  double seconds = 0;
  std::optional<double> psnr, mpsnr, upsnr;
  long long gaussians = 0;
};

std::optional<double> Metric(const nlohmann::json& metrics, const char* key) {
  if (!metrics.is_object() || !metrics.contains(key) ||
      !metrics[key].is_number())
    return std::nullopt;
  return metrics[key].get<double>();
}

std::string Cell(const std::optional<double>& v) {
  if (!v) return "n/a";
  char b[32];
  std::snprintf(b, sizeof(b), "%.2f", *v);
  return b;
}

// One fit; a fit that finished in an earlier run of the bench is read back.
BudgetRow Fit(const BudgetOptions& o, const fs::path& dataset, int factor,
              int iterations) {
  char name[64];
  std::snprintf(name, sizeof(name), "f%d_i%d%s", factor, iterations,
                o.expand ? "" : "_no_expansion");
  const Workspace ws(o.workspace / name);
  bool done = false;
  if (fs::exists(ws.fit_json())) {
    const nlohmann::json j = ReadJson(ws.fit_json());
    done = j.value("iterations", 0) >= iterations;
  }
  if (!done) {
    DepthOptions d;
    d.dataset = dataset;
    d.factor = factor;
    RunDepth(ws, d);
    FitOptions f;
    f.iterations = iterations;
    f.expansion.every = std::max(1, iterations / kExpansionsPerRun);
    f.expand = o.expand;
    f.validate_every = iterations;  // the final metrics only
    f.resume = true;
    RunFit(ws, f);
  }
  const nlohmann::json j = ReadJson(ws.fit_json());
  BudgetRow row;
  row.factor = factor;
  row.iterations = iterations;
  row.seconds = j.at("seconds").at("total").get<double>();
  const nlohmann::json& m = j.at("metrics");
  row.psnr = Metric(m, "psnr");
  row.mpsnr = Metric(m, "mpsnr");
  row.upsnr = Metric(m, "upsnr");
  row.gaussians =
      j.value("static_gaussians", 0LL) + j.value("dynamic_gaussians", 0LL);
  return row;
}

// A RunRecorder-layout CSV (stage, iteration, wall_s, cpu_s, values), so
// that `pano4d plot` and PlotRunLog draw it against wall time.
void WriteCsv(const fs::path& path, int factor, std::vector<BudgetRow> rows) {
  std::sort(rows.begin(), rows.end(),
            [](const auto& a, const auto& b) { return a.seconds < b.seconds; });
  std::ostringstream s;
  s << "stage,iteration,wall_s,cpu_s,psnr,mpsnr,upsnr\n";
  const auto value = [](const std::optional<double>& v) {
    return v ? std::to_string(*v) : std::string();
  };
  for (const BudgetRow& r : rows) {
    if (r.factor != factor) continue;
    s << "budget_" << factor << "x," << r.iterations << "," << r.seconds
      << ",0," << value(r.psnr) << "," << value(r.mpsnr) << ","
      << value(r.upsnr) << "\n";
  }
  WriteFileAtomically(path, s.str());
}

}  // namespace

BenchResult RunBenchBudget(const BudgetOptions& o) {
  if (o.iterations.empty() || o.factors.empty()) {
    throw Error("pano4d bench budget", "--iterations/--factors", "",
                "need at least one value each");
  }
  EnsureDirectory(o.workspace);
  const fs::path dataset = o.workspace / "dataset";
  synth::SynthOptions s;
  s.preset = o.preset;
  synth::EnsureSynthScene(s, dataset);
  std::vector<BudgetRow> rows;
  for (int factor : o.factors)
    for (int iterations : o.iterations)
      rows.push_back(Fit(o, dataset, factor, iterations));

  std::ostringstream md;
  md << "# pano4d bench budget: " << o.preset << " synthetic scene"
     << (o.expand ? ", with expansion" : ", no expansion") << "\n\n"
     << "| resolution | iterations | wall s | Gaussians | PSNR | mPSNR | "
        "uPSNR |\n|---|---|---|---|---|---|---|\n";
  BenchResult result;
  for (const BudgetRow& r : rows) {
    md << "| " << r.factor << "x | " << r.iterations << " | "
       << static_cast<long long>(r.seconds) << " | " << r.gaussians << " | "
       << Cell(r.psnr) << " | " << Cell(r.mpsnr) << " | " << Cell(r.upsnr)
       << " |\n";
    const auto json = [](const std::optional<double>& v) {
      return v ? nlohmann::json(*v) : nlohmann::json();
    };
    result.rows.push_back({{"factor", r.factor},
                           {"iterations", r.iterations},
                           {"seconds", r.seconds},
                           {"gaussians", r.gaussians},
                           {"psnr", json(r.psnr)},
                           {"mpsnr", json(r.mpsnr)},
                           {"upsnr", json(r.upsnr)}});
  }
  md << "\nmPSNR and uPSNR need DyCheck's covisibility masks, which exist at "
        "2x only.\n";
  WriteFileAtomically(o.workspace / "budget.md", md.str());
  result.table = md.str();
  for (int factor : o.factors) {
    const fs::path csv =
        o.workspace / ("budget_" + std::to_string(factor) + "x.csv");
    WriteCsv(csv, factor, rows);
    const fs::path png = csv.parent_path() / (csv.stem().string() + ".png");
    try {
      PlotRunLog(csv, png, {"psnr", "mpsnr", "upsnr"},
                 "pano4d bench budget (" + std::to_string(factor) +
                     "x): final PSNR (dB) against wall time");
    } catch (const Error& e) {
      PANO4D_LOG(kWarning) << "bench budget: no plot for " << factor
                           << "x: " << e.what();
    }
  }
  result.table += "written to " + o.workspace.string() +
                  ": budget.md, budget_<factor>x.csv and .png\n";
  return result;
}

}  // namespace pano4d
