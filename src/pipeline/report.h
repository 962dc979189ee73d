#pragma once

// The report folder of `pano4d demo`: what a person opens first after a run
// (numbers beside the paper's, the error-against-run-time plot, pictures and
// videos of the validation and expanded views, panoramas, a PLY).

#include <filesystem>
#include <string>
#include <vector>

#include "src/core/workspace.h"

namespace pano4d {

struct ReportSummary {
  std::filesystem::path dir;
  std::vector<std::string> files;  // written, relative to dir
  std::vector<std::string> notes;  // what could not be written, and why
};

// Reads what `pano4d run` left in `workspace` (plan.json, fit.json,
// metrics/, renders/val/, the checkpoint, expansion/trajectories.json,
// panorama/) and writes `workspace`/report/ with index.md first. Throws
// pano4d::Error naming a missing input.
ReportSummary WriteReport(const Workspace& workspace);

}  // namespace pano4d
