#pragma once

// The expand stage on its own (`pano4d expand`): one panoramic expansion
// step on the Gaussians of a fit's checkpoint (trajectories, warping, the
// prior, panoramas), chained from the step before. Nothing is distilled
// back: that is what the fit does. It takes the fit's options, resolved as
// the fit resolves them, so that a step made here equals the fit's own.

#include <filesystem>

#include "src/core/workspace.h"
#include "src/pano/expansion.h"
#include "src/pipeline/fit_options.h"

namespace pano4d {

struct ExpandOptions {
  FitOptions fit;  // expansion, warp depth, prior, panorama width, seed
  int step = 0;    // e; 0: the one after the last in WS/pano4d/expand
};

struct ExpandSummary {
  ExpansionStepReport step;
  Workspace workspace;
  std::filesystem::path step_dir;  // the step's products
  std::string FullReport() const;
};

// Writes WS/pano4d/expand/step_<e>/, steps.json, trajectories.json and
// colmap/, and WS/pano4d/panorama/. Throws pano4d::Error naming the
// missing checkpoint, or the step when all have run.
ExpandSummary RunExpand(const Workspace& workspace,
                        const ExpandOptions& options);

}  // namespace pano4d
