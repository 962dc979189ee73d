#pragma once

// The view stage: a self-contained folder that a browser opens from a
// local server (index.html, viewer.js, the compact 4D scene and the
// libraries), showing the fitted scene over time with its cameras. The page
// is src/viewer/; Spark (@sparkjsdev/spark on npm) draws the splats.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "src/core/json.h"
#include "src/core/workspace.h"
#include "src/pipeline/scene_outputs.h"

namespace pano4d {

struct ViewOptions {
  std::filesystem::path out;  // empty: WS/pano4d/view
  // The page's sources (index.html, viewer.js, node_modules/ from `npm
  // ci`); empty: $PANO4D_VIEWER_DIR, else this source tree's src/viewer.
  std::filesystem::path viewer;
};

struct ViewSummary {
  std::filesystem::path out;
  std::uint64_t scene_bytes = 0;  // scene4d.json + scene4d.bin
  std::uint64_t page_bytes = 0;   // index.html, viewer.js and lib/
  // What a 3DGS PLY per time of the same scene takes (vertex data; each
  // file's header adds under 1 KB).
  std::uint64_t ply_sequence_bytes = 0;
  std::size_t static_gaussians = 0, dynamic_gaussians = 0;
  int times = 0, bases = 0;
  std::vector<std::string> notes;  // what the page does not show
  std::string FullReport() const;
};

// Writes OUT/index.html, OUT/viewer.js, OUT/lib/ (three.js, Spark and
// their licences), OUT/scene4d.json and OUT/scene4d.bin. Throws
// pano4d::Error naming the missing library and the command that installs
// it when `npm ci` has not run.
ViewSummary RunView(const Workspace& workspace, const ViewOptions& options);

// What a viewer shows beside the scene, as scene4d.json's "extras": the
// training cameras {"name", "t", "camera"} and expanded ones {"m", "e",
// "t", "camera"} (cameras as CameraToJson), the panorama centre, the
// capture's up direction (minus the cameras' mean y axis) and the extent
// (the middle camera's distance to the centre), for frusta and speeds.
Json SceneExtras(const FittedWorkspace& fitted);

// A 3DGS PLY's bytes per Gaussian at SH degree `sh_degree` (ply.h's
// layout: 14 + 3 (d + 1)^2 floats).
std::uint64_t PlyBytesPerGaussian(int sh_degree);

}  // namespace pano4d
