// pano4d eval: DyCheck-style metrics of renders against a dataset split.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "evaluation/evaluate.h"
#include "src/cli/app.h"
#include "src/cli/stages.h"

namespace pano4d::cli {
namespace {

std::filesystem::path DatasetsMeta() {
  const char* env = std::getenv("PANO4D_DATASETS_META");
  return env ? std::filesystem::path(env)
             : std::filesystem::path(PANO4D_DATASETS_META_DIR);
}

}  // namespace

int RunEval(const EvalOptions& options) {
  const Dataset dataset = LoadDataset(options.dataset, options.factor);
  const EvaluationResult result = EvaluateRenders(
      dataset, options.renders, {options.split, options.lpips_weights});
  const std::filesystem::path out =
      options.out.empty() ? std::filesystem::path(options.renders) / "metrics"
                          : std::filesystem::path(options.out);
  std::cout << WriteEvaluation(result, out, DatasetsMeta()) << "\nwritten to "
            << out.string() << ": metrics.json, metrics.md, per_frame.csv\n";
  return kExitOk;
}

void AddEvalCommand(CLI::App& app, Action* action) {
  auto options = std::make_shared<EvalOptions>();
  CLI::App* sub =
      app.add_subcommand("eval",
                         "DyCheck metrics of renders: PSNR, SSIM, LPIPS (with "
                         "--lpips-weights), each full, on covisible pixels "
                         "(m*) and on unseen pixels (u*); per-frame CSV, mean "
                         "JSON and a Markdown table beside the "
                         "paper's numbers");
  sub->add_option("--dataset", options->dataset,
                  "Dataset folder (DyCheck layout, Nvidia, Kubric-4D)")
      ->required();
  sub->add_option(
         "--renders", options->renders,
         "Folder of renders named like the dataset's frames (<id>.png)")
      ->required();
  sub->add_option("--split", options->split, "Frames to score")
      ->check(CLI::IsMember({"val", "train"}))
      ->capture_default_str();
  sub->add_option("--out", options->out,
                  "Output folder (default: <renders>/metrics)");
  sub->add_option(
      "--lpips-weights", options->lpips_weights,
      "Folder of LPIPS AlexNet v0.1 weights (.npy files; see "
      "scripts/lpips_weights_from_torch.py); without it LPIPS reads n/a");
  sub->add_option("--factor", options->factor,
                  "Resolution of the dataset files (DyCheck: 2)")
      ->check(CLI::IsMember({1, 2}))
      ->capture_default_str();
  sub->callback(
      [action, options] { *action = [options] { return RunEval(*options); }; });
}

}  // namespace pano4d::cli
