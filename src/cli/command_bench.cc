// pano4d bench: speed and accuracy tables (src/lab/bench.h), printed as
// a table or with --json one JSON object per row.
#include <cstdio>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/strings.h"
#include "src/lab/bench.h"

namespace pano4d::cli {
namespace {

// The rows, or with `json` one JSON object per line.
int Print(const BenchResult& r, bool json) {
  if (!json) {
    std::printf("%s", r.table.c_str());
    return kExitOk;
  }
  for (const nlohmann::json& row : r.rows) std::cout << row.dump() << "\n";
  return kExitOk;
}

void AddBenchCamera(CLI::App* bench, Action* action) {
  struct Options : BenchCameraOptions {
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = bench->add_subcommand(
      "camera",
      "Every camera model: round-trip error over the image against ns per "
      "call");
  sub->add_option("--grid", o->grid, "Samples along x (y gets 3/4 as many)")
      ->check(InRange(2, 4096))
      ->capture_default_str();
  sub->add_option("--min-seconds", o->min_seconds,
                  "Minimum timing per measurement")
      ->check(InRange(0.001, 60.0))
      ->capture_default_str();
  sub->add_flag("--json", o->json,
                "One JSON object per line instead of a table");
  sub->callback([action, o] {
    *action = [o] { return Print(RunBenchCamera(*o), o->json); };
  });
}

void AddBenchRender(CLI::App* bench, Action* action) {
  struct Options : BenchRenderOptions {
    int width = 0, height = 0;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = bench->add_subcommand(
      "render",
      "Rasterizer speed: forward ms, fps and Gaussian-pixel evaluations per "
      "second");
  sub->add_option("--workspace,--checkpoint", o->workspace,
                  "Time the scene `pano4d fit` fitted in this workspace "
                  "(its checkpoint: the Gaussians a real scene has) from its "
                  "training cameras instead of random Gaussians")
      ->check(CLI::ExistingDirectory);
  sub->add_option("--gaussians", o->gaussians,
                  "Scene sizes (default 10k, 100k, 500k)")
      ->delimiter(',');
  sub->add_option("--size", o->sizes,
                  "Image sizes WxH (default 480x360, 960x720)")
      ->delimiter(',');
  sub->add_option("--width", o->width, "Image width (with --height: one size)");
  sub->add_option("--height", o->height,
                  "Image height (with --width: one size)");
  sub->add_option("--repeats", o->repeats,
                  "Timed runs per case; the median is reported")
      ->check(InRange(1, 1000))
      ->capture_default_str();
  sub->add_flag("--json", o->json,
                "One JSON object per line and case (gaussians, width, height, "
                "threads, forward_ms, forward_backward_ms)");
  sub->callback([action, o] {
    *action = [o] {
      if (o->width > 0 || o->height > 0) {
        if (o->width <= 0 || o->height <= 0) {
          throw Error("--width/--height", "", SizeText(o->width, o->height),
                      "give both, positive");
        }
        o->sizes = {SizeText(o->width, o->height)};
      }
      return Print(RunBenchRender(*o), o->json);
    };
  });
}

}  // namespace

void AddBenchCommand(CLI::App& app, Action* action) {
  CLI::App* bench = app.add_subcommand(
      "bench", "Speed and accuracy tables (error against run time)");
  bench->require_subcommand(1);
  AddBenchCamera(bench, action);
  AddBenchRender(bench, action);
  AddBenchStability(bench, action);
  AddBenchBudget(bench, action);
  AddBenchDatasets(bench, action);
}

}  // namespace pano4d::cli
