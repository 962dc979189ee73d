// pano4d expand: one panoramic expansion step on its own, from the Gaussians
// that `pano4d fit` left in its checkpoint: trajectories, warping, the prior,
// panoramas. Nothing is distilled back (that is what fit does).
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "src/cli/app.h"
#include "src/cli/expansion_outputs.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/frames.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/gs/trainer.h"
#include "src/pano/expansion.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

struct ExpandCommandOptions {
  fs::path workspace;
  ExpansionOptions expansion;
  std::string warp_depth;  // --warp-depth; empty: ResolveWarpDepth's default
  int step = 0;            // 0: the one after the last in WS/pano4d/expand
  std::string prior_cmd;
  int panorama_width = 1024;
};

int RunExpandCommand(ExpandCommandOptions o) {
  const fs::path ws = o.workspace;
  const fs::path ckpt = ws / "pano4d" / "checkpoints" / "fit.ckpt";
  if (!fs::exists(ckpt)) {
    throw Error(ckpt.string(), "file", "",
                "missing: run `pano4d fit --workspace " + ws.string() +
                    "` first; expand starts from its Gaussians");
  }
  const fs::path out = ws / "pano4d" / "expand";
  const fs::path steps_path = out / "steps.json";
  nlohmann::json steps =
      fs::exists(steps_path) ? ReadJson(steps_path) : nlohmann::json::array();
  int last = 0;
  for (const auto& s : steps) last = std::max(last, s.at("step").get<int>());
  const int e = o.step > 0 ? o.step : last + 1;
  if (e > o.expansion.geometry.steps) {
    throw Error(steps_path.string(), "step", std::to_string(e),
                "all " + std::to_string(o.expansion.geometry.steps) +
                    " steps have run; pass --step N to run one again or "
                    "--expansion-steps to go further");
  }
  o.expansion.Check();
  const WorkspaceFrames frames = ReadWorkspaceFrames(ws);
  o.expansion.warp_depth = ResolveWarpDepth(o.warp_depth, frames.depth_source);
  TrainerOptions trainer_options;
  trainer_options.iterations = 1;
  Trainer trainer(ReadCheckpointScene(ckpt), LoadTrainingViews(frames.train),
                  trainer_options);
  o.expansion.gaussian_refinement = true;  // placement is reported
  const std::unique_ptr<Prior> prior = MakePrior(o.prior_cmd, out / "prior");
  Expansion expansion(o.expansion, out, prior.get());
  if (e > 1 && fs::exists(expansion.StepDir(e - 1) / "cameras.json")) {
    expansion.Reload(trainer, e - 1);  // chaining from the step before
  }
  // The panoramas show the fitted Gaussians, not the step's untrained ones.
  const GaussianScene fitted = trainer.scene();
  const ExpansionStepReport report = expansion.RunStep(&trainer, e);
  PANO4D_LOG(kInfo) << report.Brief();
  steps.push_back(report.ToJson());
  WriteJson(steps_path, steps);
  std::vector<ExpandedView> cameras;
  for (const ExpandedView& v : expansion.cameras())
    if (v.e == e) cameras.push_back(v);
  WriteTrajectories(out, cameras, trainer.views());
  WritePanoramas(ws / "pano4d" / "panorama", fitted, expansion.frame(),
                 o.panorama_width, o.panorama_width / 2);
  std::printf(
      "pano4d expand: step %d (%.1f deg), %d views, holes %.1f%%, prior %s%s\n"
      "  products   %s\n  cameras    %s (COLMAP model: %s)\n"
      "  panoramas  %s\n",
      e, report.angle_degrees, report.views, 100 * report.hole_fraction,
      report.prior.c_str(),
      report.fallbacks > 0 ? " (fell back; see the log)" : "",
      expansion.StepDir(e).c_str(), (out / "trajectories.json").c_str(),
      (out / "colmap").c_str(), (ws / "pano4d" / "panorama").c_str());
  return kExitOk;
}

}  // namespace

void AddExpandCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<ExpandCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "expand",
      "Run one panoramic expansion step on the fitted Gaussians: "
      "trajectories, warping, prior, panoramas (no refinement)");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (WS/pano4d/checkpoints/fit.ckpt from "
                  "`pano4d fit`)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--step", o->step,
                  "The step e (angle e x alpha); default: the one after the "
                  "last that ran")
      ->check(CLI::PositiveNumber);
  AddExpansionFlags(sub, &o->expansion, &o->warp_depth, &o->prior_cmd,
                    &o->panorama_width);
  sub->footer(
      "Writes WS/pano4d/expand/step_<e>/dir_<m>/{warped,mask,refined}/ and "
      "cameras.json, WS/pano4d/expand/trajectories.json and colmap/ (the "
      "step's cameras beside the training ones), steps.json, and "
      "WS/pano4d/panorama/.");
  sub->callback(
      [action, o] { *action = [o] { return RunExpandCommand(*o); }; });
}

}  // namespace pano4d::cli
