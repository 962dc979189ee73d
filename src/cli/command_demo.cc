// pano4d demo: the built-in synthetic scene end to end (synth, the planned
// pipeline of `pano4d run --eval`, and a report folder), within a budget a
// 2-core machine finishes in minutes.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/timer.h"
#include "src/core/workspace_lock.h"
#include "src/datasets/synth_generate.h"
#include "src/pipeline/run.h"

namespace pano4d::cli {
namespace {

// The demo's fit: two expansions (three steps each with the default E = 6)
// in 3000 iterations, and six points on the error-against-time plot; with
// --iterations alone the same proportions.
constexpr int kDemoIterations = 3000;
constexpr int kDemoExpansions = 2;
constexpr int kDemoValidations = 6;

}  // namespace

void AddDemoCommand(CLI::App& app, Action* action) {
  struct Options {
    std::string preset = "small";
    RunOptions run;
  };
  auto o = std::make_shared<Options>();
  o->run.workspace = "pano4d_demo";
  o->run.eval = true;
  FitOptions& fit = o->run.fit;
  fit.iterations = kDemoIterations;
  fit.expansion.every = kDemoIterations / (kDemoExpansions + 1);
  fit.validate_every = kDemoIterations / kDemoValidations;
  CLI::App* sub = app.add_subcommand(
      "demo",
      "The built-in synthetic scene end to end: generate it, plan and run "
      "every stage (poses and depth given, fit with panoramic expansion, "
      "DyCheck metrics), and write a report");
  sub->add_option("--workspace", o->run.workspace,
                  "Where everything goes (the dataset in WS/dataset, the "
                  "report in WS/report)")
      ->capture_default_str();
  AddPresetOption(sub, &o->preset);
  AddFitOptions(sub, &fit);
  sub->footer(
      "The scene's seed is the fit's (--seed). With --iterations alone, two "
      "expansions and six validations are spread over them. Writes "
      "WS/report/index.md (metrics beside the paper's rows, the stage plan "
      "and times, the error-against-run-time plot, validation and "
      "expanded-view renders as PNG sheets and MP4, panoramas, a PLY). Run "
      "it again to resume; `pano4d eval --dataset WS/dataset --renders "
      "WS/pano4d/renders/val` reproduces the metrics.");
  sub->callback([action, o, sub] {
    FitOptions& f = o->run.fit;
    const int it = f.iterations.value_or(kDemoIterations);
    if (sub->count("--expand-every") == 0)
      f.expansion.every = std::max(1, it / (kDemoExpansions + 1));
    if (sub->count("--validate-every") == 0)
      f.validate_every = std::max(1, it / kDemoValidations);
    // The demo's 3000 is its schedule, not a length asked for: the
    // convergence stop may end it, as a fit's default schedule.
    if (sub->count("--iterations") == 0 && !f.converge_on)
      f.converge_on = ConvergeOn::kAuto;
    *action = [o] {
      const FolderLock lock = LockWorkspace(o->run.workspace);
      Timer total;
      o->run.dataset = o->run.workspace / "dataset";
      synth::SynthOptions s;
      s.preset = o->preset;
      s.seed = static_cast<std::uint32_t>(o->run.fit.seed);
      const bool made = synth::EnsureSynthScene(s, o->run.dataset);
      std::printf("pano4d: the synthetic scene in %s is %s\n",
                  o->run.dataset.c_str(), made ? "new" : "from an earlier run");
      const RunSummary r = RunPipeline(o->run, &std::cout);
      std::printf("pano4d demo: done in %.1f s; the report is %s\n",
                  total.WallSeconds(), (r.report.dir / "index.md").c_str());
      for (const std::string& f : r.report.files)
        std::printf("  %s\n", (r.report.dir / f).c_str());
      for (const std::string& n : r.report.notes)
        std::printf("  not written: %s\n", n.c_str());
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
