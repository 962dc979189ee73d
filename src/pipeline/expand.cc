#include "src/pipeline/expand.h"

#include <algorithm>
#include <cstdio>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/strings.h"
#include "src/pano/prior.h"
#include "src/pano/trajectory_io.h"
#include "src/pipeline/expansion_outputs.h"
#include "src/pipeline/fit.h"

namespace pano4d {
namespace fs = std::filesystem;

std::string ExpandSummary::FullReport() const {
  const fs::path out = workspace.expand();
  return StringPrintf(
      "pano4d expand: step %d (%.1f deg), %d views, holes %.1f%%, prior %s%s\n"
      "  products   %s\n  cameras    %s (COLMAP model: %s)\n"
      "  panoramas  %s\n",
      step.step, step.angle_degrees, step.views, 100 * step.hole_fraction,
      step.prior.c_str(), step.fallbacks > 0 ? " (fell back; see the log)" : "",
      step_dir.c_str(), (out / "trajectories.json").c_str(),
      (out / "colmap").c_str(), workspace.panorama().c_str());
}

ExpandSummary RunExpand(const Workspace& ws, const ExpandOptions& options) {
  const fs::path ckpt = ws.checkpoint();
  if (!fs::exists(ckpt)) {
    throw Error(ckpt.string(), "file", "",
                "missing: run `pano4d fit --workspace " + ws.root().string() +
                    "` first; expand starts from its Gaussians");
  }
  const fs::path out = ws.expand();
  const fs::path steps_path = out / "steps.json";
  nlohmann::json steps =
      fs::exists(steps_path) ? ReadJson(steps_path) : nlohmann::json::array();
  int last = 0;
  for (const auto& s : steps) last = std::max(last, s.at("step").get<int>());
  const int steps_total = options.fit.expansion.geometry.steps;
  const int e = options.step > 0 ? options.step : last + 1;
  if (e > steps_total) {
    throw Error(steps_path.string(), "step", std::to_string(e),
                "all " + std::to_string(steps_total) +
                    " steps have run; pass --step N to run one again or "
                    "--expansion-steps to go further");
  }
  options.fit.expansion.Check();
  const WorkspaceFrames frames = ReadWorkspaceFrames(ws.root());
  FitOptions o = ResolveFitOptions(options.fit, FitInputOf(frames));
  o.expansion.gaussian_refinement = true;  // placement is reported
  const std::unique_ptr<Trainer> owned = MakeFitTrainer(
      ReadCheckpointScene(ckpt), LoadTrainingViews(frames.train), o);
  Trainer& trainer = *owned;
  const std::unique_ptr<Prior> prior = MakePrior(o.prior_cmd, out / "prior", o.prior_timeout);
  Expansion expansion(o.expansion, o.seed, out, prior.get());
  if (e > 1 && fs::exists(expansion.StepDir(e - 1) / "cameras.json")) {
    expansion.Reload(trainer, e - 1);  // chaining from the step before
  }
  // The panoramas show the fitted Gaussians, not the step's untrained ones.
  const GaussianScene fitted = trainer.scene();
  ExpandSummary summary;
  summary.workspace = ws;
  summary.step = expansion.RunStep(&trainer, e);
  summary.step_dir = expansion.StepDir(e);
  PANO4D_LOG(kInfo) << summary.step.Brief();
  steps.push_back(summary.step.ToJson());
  WriteJson(steps_path, steps);
  std::vector<ExpandedView> cameras;
  for (const ExpandedView& v : expansion.cameras())
    if (v.e == e) cameras.push_back(v);
  WriteTrajectories(out, cameras, SourceCamerasOf(trainer.views()));
  WritePanoramas(ws.panorama(), fitted, expansion.frame(), o.panorama_width,
                 o.panorama_width / kPanoramaAspect);
  return summary;
}

}  // namespace pano4d
