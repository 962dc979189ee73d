// pano4d bench stability, budget and datasets: the suites that fit scenes
// (the synthetic scene through the fit controller; a benchmark's scenes
// through `pano4d run`) (src/lab/bench.h).
#include <cstdio>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/json.h"
#include "src/lab/bench.h"

namespace pano4d::cli {

void AddBenchStability(CLI::App* bench, Action* action) {
  struct Options : StabilityOptions {
    bool json = false;
    std::string out;  // also written here, as JSON
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = bench->add_subcommand(
      "stability",
      "The stiff and extreme suite: expansion angles up to 90 degrees, the "
      "panorama's seam and poles, near-degenerate covariances, very near and "
      "far geometry, scenes scaled by 1e-3 and 1e3, a static-camera video; "
      "per case the count of non-finite values (must be 0) and metrics");
  sub->add_option("--fit-iterations", o->fit_iterations,
                  "Iterations of the short fits on the tiny scene (each as "
                  "`pano4d fit --no-expansion` runs it)")
      ->capture_default_str();
  sub->add_flag("--json", o->json, "JSON instead of a table");
  sub->add_option("--out", o->out, "Also write the results to this JSON file");
  sub->footer("Exit status 1 when any case produced a non-finite value.");
  sub->callback([action, o] {
    *action = [o] {
      const StabilityResult r = RunBenchStability(*o);
      if (!o->out.empty())
        WriteJson(o->out,
                  {{"cases", r.bench.rows}, {"non_finite", r.non_finite}});
      if (o->json) {
        std::cout << nlohmann::json(r.bench.rows).dump(2) << "\n";
      } else {
        std::printf("%s", r.bench.table.c_str());
      }
      if (r.non_finite == 0) return kExitOk;
      std::fprintf(stderr, "pano4d bench stability: %lld non-finite values\n",
                   static_cast<long long>(r.non_finite));
      return kExitError;
    };
  });
}

void AddBenchBudget(CLI::App* bench, Action* action) {
  auto o = std::make_shared<BudgetOptions>();
  CLI::App* sub = bench->add_subcommand(
      "budget",
      "Error against run time across budgets: the synthetic scene fitted at "
      "several iteration counts and resolutions; a table and a plot of "
      "PSNR / mPSNR / uPSNR against wall time per resolution");
  sub->add_option("--workspace", o->workspace,
                  "Where the runs go (each in its own workspace; a finished "
                  "one is read back, so the bench resumes)")
      ->capture_default_str();
  AddPresetOption(sub, &o->preset);
  sub->add_option("--iterations", o->iterations, "Budgets (iterations)")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_option("--factors", o->factors,
                  "Resolution divisors of the dataset (2: DyCheck's "
                  "evaluation resolution; 1: full)")
      ->delimiter(',')
      ->capture_default_str();
  AddNoExpansionFlag(sub, &o->expand);
  sub->footer(
      "An expansion every iterations/5 (the paper's 2000 of 10000). Writes "
      "WS/budget.md, WS/budget_<factor>x.csv and WS/budget_<factor>x.png. "
      "The default (1k-10k at two resolutions) takes hours on 2 cores.");
  sub->callback([action, o] {
    *action = [o] {
      std::printf("%s", RunBenchBudget(*o).table.c_str());
      return kExitOk;
    };
  });
}

void AddBenchDatasets(CLI::App* bench, Action* action) {
  auto o = std::make_shared<BenchDatasetsOptions>();
  CLI::App* sub = bench->add_subcommand(
      "datasets",
      "Every scene under a benchmark root through `pano4d run --eval` (one "
      "workspace per scene, resumable): a Markdown and CSV table of the "
      "metrics, seconds and peak memory per scene and per suite, beside the "
      "published rows of datasets_meta/");
  sub->add_option("--root", o->root,
                  "A folder of scene folders (Nvidia, DyCheck, Kubric-4D, "
                  "pano4d synth layouts)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--suite", o->suite, "Only the scenes of this suite")
      ->check(CLI::IsMember({"nvidia", "dycheck", "kubric", "synth"}));
  sub->add_option("--scenes", o->scenes,
                  "Only these scene folders (comma-separated names)")
      ->delimiter(',');
  sub->add_option("--iterations", o->iterations,
                  "Fit iterations per scene (default: run's schedule)")
      ->check(Positive());
  AddLpipsWeightsOption(sub, &o->lpips_weights);
  sub->add_option(
         "--priors", o->priors,
         "A root of learned priors per scene: ROOT/<scene>/ in any layout "
         "--priors reads (the data root itself when each scene "
         "folder holds its own); scenes without are run without")
      ->check(CLI::ExistingDirectory);
  sub->add_option("--workspace", o->workspace,
                  "Where the scenes' workspaces go (WS/<scene>) and the "
                  "tables (WS/datasets.md, WS/datasets.csv)")
      ->capture_default_str();
  sub->footer(
      "Each scene runs as its own `pano4d run` process (log in "
      "WS/<scene>/pano4d/logs/bench_run.log) at its protocol's factor "
      "(Kubric-4D 1, the others 2). A scene that finished with the same "
      "command is read back from WS/<scene>/pano4d/bench_entry.json; a "
      "failed scene is a row with its error, and the others go on. The exit "
      "status is 1 when any scene failed.");
  sub->callback([action, o] {
    *action = [o] {
      const BenchResult r = RunBenchDatasets(*o);
      std::printf("%s", r.table.c_str());
      for (const nlohmann::json& row : r.rows)
        if (row.value("status", "") != "done") return kExitError;
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
