// pano4d eval: DyCheck-style metrics of renders against a dataset split
// (src/pipeline/eval.h).
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/pipeline/eval.h"

namespace pano4d::cli {

void AddEvalCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<EvalOptions>();
  CLI::App* sub =
      app.add_subcommand("eval",
                         "DyCheck metrics of renders: PSNR, SSIM, LPIPS (with "
                         "--lpips-weights), each full, on covisible pixels "
                         "(m*) and on unseen pixels (u*); per-frame CSV, mean "
                         "JSON and a Markdown table beside the "
                         "paper's numbers");
  AddDatasetOption(sub, &o->dataset)->required();
  sub->add_option(
         "--renders", o->renders,
         "Folder of renders named like the dataset's frames (<id>.png)")
      ->required();
  sub->add_option("--split", o->split, "Frames to score")
      ->check(CLI::IsMember({"val", "train"}))
      ->capture_default_str();
  sub->add_option("--out", o->out,
                  "Output folder (default: <renders>/metrics)");
  AddLpipsWeightsOption(sub, &o->lpips_weights);
  AddFactorOption(sub, &o->factor);
  sub->callback([action, o] {
    *action = [o] {
      const EvalSummary s = RunEval(*o);
      std::cout << s.markdown << "\nwritten to " << s.out.string()
                << ": metrics.json, metrics.md, per_frame.csv\n";
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
