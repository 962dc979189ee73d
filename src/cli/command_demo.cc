// pano4d demo: the built-in synthetic scene end to end (synth, the planned
// pipeline of `pano4d run --eval`, and a report folder), within a budget a
// 2-core machine finishes in minutes.
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/run.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/timer.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

// The demo's fit: two expansions (three steps each with the default E = 6)
// in 3000 iterations: on the small scene about 18-19 dB uPSNR against 13
// without expansion, and the covisible mPSNR within 0.2 dB of it
// (docs/ARCHITECTURE.md, "src/pano"), in minutes on 2 cores.
constexpr int kDemoIterations = 3000;
constexpr int kDemoExpansions = 2;
constexpr int kDemoValidations = 6;  // points on the error-against-time plot

struct DemoOptions {
  fs::path workspace = "pano4d_demo";
  std::string preset = "small";
  std::uint32_t seed = 0;
  int iterations = kDemoIterations;
  bool no_expansion = false;
};

int RunDemo(const DemoOptions& o) {
  if (o.iterations < 1) {
    throw Error("--iterations", "", std::to_string(o.iterations),
                "must be at least 1");
  }
  Timer total;
  const fs::path dataset = o.workspace / "dataset";
  SynthCommandOptions s;
  s.synth.preset = o.preset;
  s.synth.seed = o.seed;
  s.out = dataset.string();
  EnsureSynthScene(s);
  RunCommandOptions r;
  r.dataset = dataset;
  r.workspace = o.workspace;
  r.eval = true;
  r.fit.trainer.iterations = o.iterations;
  r.fit.expansion.every = std::max(1, o.iterations / (kDemoExpansions + 1));
  r.fit.validate_every = std::max(1, o.iterations / kDemoValidations);
  r.fit.no_expansion = o.no_expansion;
  r.fit.seed = o.seed;
  RunReport run;
  RunPipeline(r, &run);
  const ReportSummary& report = run.report;
  std::printf("pano4d demo: done in %.1f s; the report is %s\n",
              total.WallSeconds(), (report.dir / "index.md").c_str());
  for (const std::string& f : report.files)
    std::printf("  %s\n", (report.dir / f).c_str());
  for (const std::string& n : report.notes)
    std::printf("  not written: %s\n", n.c_str());
  return kExitOk;
}

}  // namespace

void AddDemoCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* sub = app.add_subcommand(
      "demo",
      "The built-in synthetic scene end to end: generate it, plan and run "
      "every stage (poses and depth given, fit with panoramic expansion, "
      "DyCheck metrics), and write a report");
  sub->add_option("--workspace", o->workspace,
                  "Where everything goes (the dataset in WS/dataset, the "
                  "report in WS/report)")
      ->capture_default_str();
  sub->add_option("--preset", o->preset, "Synthetic scene: tiny, small, medium")
      ->check(CLI::IsMember({"tiny", "small", "medium"}))
      ->capture_default_str();
  sub->add_option("--seed", o->seed, "Seed of the scene and the fit")
      ->capture_default_str();
  sub->add_option("--iterations", o->iterations,
                  "Fit iterations (two expansions are spread over them)")
      ->capture_default_str();
  sub->add_flag("--no-expansion", o->no_expansion,
                "The same demo without panoramic expansion (the baseline)");
  sub->footer(
      "Writes WS/report/index.md (metrics beside the paper's rows, the "
      "stage plan and times, the error-against-run-time plot, validation "
      "and expanded-view renders as PNG sheets and MP4, panoramas, a PLY). "
      "Run it again to resume; `pano4d eval --dataset WS/dataset --renders "
      "WS/pano4d/renders/val` reproduces the metrics.");
  sub->callback([action, o] { *action = [o] { return RunDemo(*o); }; });
}

}  // namespace pano4d::cli
