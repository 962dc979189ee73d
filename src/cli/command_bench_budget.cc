// pano4d bench budget: error against run time across budgets. The
// synthetic scene is fitted at several iteration counts and resolutions;
// the final PSNR / mPSNR / uPSNR against the wall time of each fit go into
// a table and a plot per resolution, so that a user can choose a budget.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "evaluation/plot.h"
#include "src/cli/app.h"
#include "src/cli/stages.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/log.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

// The paper's schedule, an expansion every 2000 of 10000 iterations, at
// every budget: five per run.
constexpr int kExpansionsPerRun = 5;

struct BudgetOptions {
  fs::path workspace = "pano4d_budget";
  std::string preset = "small";
  std::vector<int> iterations = {1000, 2000, 5000, 10000};
  // DyCheck evaluates at 2x (its covisibility masks exist only there); 1x
  // is the full resolution, scored by PSNR alone.
  std::vector<int> factors = {2, 1};
  bool no_expansion = false;
};

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
  const fs::path ws = o.workspace / ("f" + std::to_string(factor) + "_i" +
                                     std::to_string(iterations) +
                                     (o.no_expansion ? "_no_expansion" : ""));
  const fs::path fit_json = ws / "pano4d" / "fit.json";
  bool done = false;
  if (fs::exists(fit_json)) {
    const nlohmann::json j = ReadJson(fit_json);
    done = j.value("iterations", 0) >= iterations;
  }
  if (!done) {
    DepthCommandOptions d;
    d.workspace = ws;
    d.dataset = dataset;
    d.factor = factor;
    RunDepthCommand(d);
    FitCommandOptions f;
    f.workspace = ws;
    f.trainer.iterations = iterations;
    f.expansion.every = std::max(1, iterations / kExpansionsPerRun);
    f.no_expansion = o.no_expansion;
    f.validate_every = iterations;  // the final metrics only
    f.resume = true;
    RunFitCommand(f);
  }
  const nlohmann::json j = ReadJson(fit_json);
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

int RunBenchBudget(const BudgetOptions& o) {
  if (o.iterations.empty() || o.factors.empty()) {
    throw Error("pano4d bench budget", "--iterations/--factors", "",
                "need at least one value each");
  }
  EnsureDirectory(o.workspace);
  const fs::path dataset = o.workspace / "dataset";
  SynthCommandOptions s;
  s.synth.preset = o.preset;
  s.out = dataset.string();
  EnsureSynthScene(s);
  std::vector<BudgetRow> rows;
  for (int factor : o.factors)
    for (int iterations : o.iterations)
      rows.push_back(Fit(o, dataset, factor, iterations));

  std::ostringstream md;
  md << "# pano4d bench budget: " << o.preset << " synthetic scene"
     << (o.no_expansion ? ", no expansion" : ", with expansion") << "\n\n"
     << "| resolution | iterations | wall s | Gaussians | PSNR | mPSNR | "
        "uPSNR |\n|---|---|---|---|---|---|---|\n";
  for (const BudgetRow& r : rows) {
    md << "| " << r.factor << "x | " << r.iterations << " | "
       << static_cast<long long>(r.seconds) << " | " << r.gaussians << " | "
       << Cell(r.psnr) << " | " << Cell(r.mpsnr) << " | " << Cell(r.upsnr)
       << " |\n";
  }
  md << "\nmPSNR and uPSNR need DyCheck's covisibility masks, which exist at "
        "2x only.\n";
  WriteFileAtomically(o.workspace / "budget.md", md.str());
  std::printf("%s", md.str().c_str());
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
  std::printf("written to %s: budget.md, budget_<factor>x.csv and .png\n",
              o.workspace.c_str());
  return kExitOk;
}

}  // namespace

void AddBenchBudget(CLI::App& bench, Action* action) {
  auto o = std::make_shared<BudgetOptions>();
  CLI::App* sub = bench.add_subcommand(
      "budget",
      "Error against run time across budgets: the synthetic scene fitted at "
      "several iteration counts and resolutions; a table and a plot of "
      "PSNR / mPSNR / uPSNR against wall time per resolution");
  sub->add_option("--workspace", o->workspace,
                  "Where the runs go (each in its own workspace; a finished "
                  "one is read back, so the bench resumes)")
      ->capture_default_str();
  sub->add_option("--preset", o->preset, "Synthetic scene")
      ->check(CLI::IsMember({"tiny", "small", "medium"}))
      ->capture_default_str();
  sub->add_option("--iterations", o->iterations, "Budgets (iterations)")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_option("--factors", o->factors,
                  "Resolution divisors of the dataset (2: DyCheck's "
                  "evaluation resolution; 1: full)")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_flag("--no-expansion", o->no_expansion,
                "Fit without panoramic expansion");
  sub->footer(
      "An expansion every iterations/5 (the paper's 2000 of 10000). Writes "
      "WS/budget.md, WS/budget_<factor>x.csv and WS/budget_<factor>x.png. "
      "The default (1k-10k at two resolutions) takes hours on 2 cores.");
  sub->callback([action, o] { *action = [o] { return RunBenchBudget(*o); }; });
}

}  // namespace pano4d::cli
