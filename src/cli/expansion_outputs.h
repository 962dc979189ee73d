#pragma once
// What `pano4d fit` and `pano4d expand` share about the expansion: its flags,
// its prior, and what it leaves in the workspace for people and viewers
// (trajectories as JSON and as a COLMAP model, equirectangular panoramas).

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "src/gs/scene.h"
#include "src/gs/trainer.h"
#include "src/pano/expansion.h"
#include "src/pano/frame.h"
#include "src/pano/prior.h"
#include "src/pano/trajectory.h"

namespace CLI {
class App;
}

namespace pano4d::cli {

// `value` with leading zeros to `width` digits: file names that sort (5:
// frames and times, 2: expansion steps).
std::string Padded(int value, int width);

// The flags both commands take: --directions, --expansion-steps, --alpha,
// --expansion-stride, --planar-expansion, --warp-depth (into `warp_depth`,
// empty when not given: ResolveWarpDepth), --prior-cmd, --panorama-width.
void AddExpansionFlags(CLI::App* sub, ExpansionOptions* options,
                       std::string* warp_depth, std::string* prior_cmd,
                       int* panorama_width);

// --warp-depth as given ("given" or "rendered"), or when empty the default
// for the frames' depth source (WorkspaceFrames::depth_source): the given
// depth on depth the dataset gives, measured on the small synthetic scene
// (docs/ARCHITECTURE.md, "Warping with the given depth"); rendered depth
// on depth pano4d estimated (stereo has holes and errors at the edges the
// warp needs most; not measured there).
WarpDepth ResolveWarpDepth(const std::string& flag,
                           const std::string& depth_source);

// The prior the expansion fills holes with: the external command when given
// (its folders under work_dir), falling back to the CPU geometry prior when
// it fails; the CPU prior alone otherwise.
std::unique_ptr<Prior> MakePrior(const std::string& command,
                                 const std::filesystem::path& work_dir);

// dir/trajectories.json (every expanded camera, with m, e, t) and
// dir/colmap/{cameras,images,points3D}.txt: the training cameras (named
// source/<frame>) beside the expanded ones (step_<e>/dir_<m>/<t>.png), so
// that COLMAP's GUI (File > Import model) shows them together.
void WriteTrajectories(const std::filesystem::path& dir,
                       const std::vector<ExpandedView>& cameras,
                       const std::vector<TrainingView>& sources);

// dir/<t>.png for every time (all Gaussians posed at t) and dir/static.png
// (static Gaussians only: the content aggregated over time), equirectangular
// in the panorama frame, width x height.
void WritePanoramas(const std::filesystem::path& dir,
                    const GaussianScene& scene, const PanoramaFrame& frame,
                    int width, int height);

}  // namespace pano4d::cli
