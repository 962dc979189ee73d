#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include "src/geometry/point_cloud.h"
#include "src/gs/scene_editor.h"
#include "src/pano/frame.h"
#include "src/pano/free_space.h"
#include "src/pano/layout.h"
#include "src/pano/prior.h"
#include "src/pano/trajectory.h"

namespace pano4d {

// The depth a source frame is warped into the expanded views with.
enum class WarpDepth {
  // The paper's: z-depth rendered from the current Gaussians (where they
  // are opaque enough to trust).
  kRendered,
  // The frame's own depth map where it has depth (a dataset's, or an
  // estimate aligned to the SfM points), rendered depth elsewhere: the
  // rendered depth is a worse copy of depth the dataset gives (flying
  // pixels at soft edges, the fit's error everywhere). Measured in
  // docs/experiments/2026-11-24-warp-given-depth-and-refine-outside-3.md.
  kGiven,
};
const char* WarpDepthName(WarpDepth w);  // "rendered", "given"

// The progressive expansion inside fit (DESIGN.md, "Warping" to
// "Refinement"; paper defaults).
struct ExpansionOptions {
  ExpansionGeometry geometry;
  // An expansion every `every` iterations (those strictly before the end);
  // the E steps are spread over them: expansion k of K runs the steps up
  // to ceil(E k / K).
  int every = 2000;
  double refine_weight = 0.1;  // L_refine
  // L_refine's weight on the pixels outside M_e (the warped frames),
  // relative to those in it; 0 is the paper's loss, masked to M_e. Masked,
  // the Gaussians that fill M_e spread over the warped content around it,
  // which no training frame sees from there; the warped pixels are the
  // other views' evidence of the geometry from the expanded cameras.
  // Measured in docs/experiments/2026-11-23-refine-outside-me.md and
  // 2026-11-24-warp-given-depth-and-refine-outside-3.md.
  double refine_outside_weight = 3.0;
  // L_refine on one expanded view every this many iterations.
  int refine_every = 1;
  // Source frames: every time_stride-th training frame in time order (the
  // views kept in memory: directions x steps x frames / stride).
  int time_stride = 4;
  // Ablation: no progressive expansion, one step at the full angle E alpha.
  bool one_step = false;
  // Ablation: expanded views are produced and written, but not distilled
  // into the Gaussians (no new Gaussians, no L_refine).
  bool gaussian_refinement = true;
  // New Gaussians: every stride-th pixel of M_e not yet covered (rendered
  // alpha below kCoveredAlpha), thinned by a voxel grid of voxel_pixels at
  // the median depth.
  int new_gaussian_stride = 2;
  double voxel_pixels = 2.0;
  // Free-space carving (Carve): every carve_every iterations once a step has
  // run, and at every step, static Gaussians in known empty space are
  // removed (a floater that no view's loss reaches: in front of a surface
  // that a training frame saw, out of that frame's sight). 0: only at the
  // steps.
  int carve_every = 100;
  WarpDepth warp_depth = WarpDepth::kRendered;

  void Check() const;  // throws pano4d::Error naming the field
  nlohmann::json ToJson() const;
};

// Which steps run when: for a run of `iterations`, the steps due at the
// expansion after `iteration` iterations (empty when none is due).
std::vector<int> StepsDueAt(const ExpansionOptions& options,
                            std::int64_t iteration, int iterations);
// The iteration of the run's last expansion (0: none).
std::int64_t LastExpansionIteration(const ExpansionOptions& options,
                                    int iterations);
// The last step that ran before iteration `before` (0: none): where a fit
// resumed at `before` continues the expansion from.
int LastStepBefore(const ExpansionOptions& options, std::int64_t before,
                   int iterations);

struct ExpansionStepReport {
  int step = 0;
  double angle_degrees = 0.0;
  int views = 0;
  double hole_fraction = 0.0;       // mean over views of |M_e| / pixels
  double prefilled_fraction = 0.0;  // of M_e, filled by chaining step e-1
  double crack_fraction = 0.0;      // of M_e, cracks (CountCracks, warp.h)
  std::int64_t new_gaussians = 0;
  std::int64_t rejected_in_free_space =
      0;                    // candidates in known empty space (InFreeSpace)
  std::int64_t carved = 0;  // static Gaussians removed by Carve first
  int layout_planes = 0;    // box faces on a fitted plane (layout.h); -1: none
  std::string prior;        // the prior that filled (or "command -> geometry")
  int fallbacks = 0;
  double seconds = 0.0;
  std::string Brief() const;
  nlohmann::json ToJson() const;
};

// Runs expansion steps on a fit's current Gaussians (through SceneEditor)
// and serves the refinement views to its extra_view hook. Products go under
// `out_dir` (WS/pano4d/expansion): frame.json,
// step_<e>/dir_<m>/{warped,mask,refined} PNGs and depth .npy named after the
// source frame, cameras.json per step.
class Expansion {
 public:
  // `seed` with the iteration chooses each step's refinement view.
  Expansion(ExpansionOptions options, std::uint64_t seed,
            std::filesystem::path out_dir, Prior* prior);

  // Step e (1..E; angle e alpha): depth rendered at the source cameras and
  // held fixed; the original frames warped into every direction's cameras;
  // holes pre-filled from step e-1's refined frames when it ran; the prior
  // fills the rest; Gaussians added in M_e where the current ones show
  // nothing (rendered alpha < 0.5) and no training frame saw empty space;
  // refinement views (L_refine on M_e) queued.
  ExpansionStepReport RunStep(SceneEditor* fit, int e);

  // Before the first step of a fresh fit: the layout of the sources'
  // static pixels (their training depth) and, as opaque Gaussians
  // (kShellOpacity) in the faces' colours, its faces where no training
  // frame saw them (Look: unseen or unknown; off the fitted planes, nor
  // anything kShellReach spacings around). A novel view then shows the
  // room's surfaces where nothing was seen from the first iteration on,
  // not the black background until a step reaches there; each step carves
  // what of the shell off the planes its views see through (Carve).
  // Nothing without Gaussian refinement, whose ablation fits as without
  // expansion.
  struct Shell {
    int planes = -1;  // box faces on a fitted plane; -1: no layout
    std::int64_t gaussians = 0;
  };
  Shell AddLayoutShell(SceneEditor* fit);

  // Removes the static Gaussians whose centre lies in known empty space
  // (InFreeSpace, free_space.h): seen through by a training frame, or seen
  // by none and seen through by a stored view's warp or by most stored
  // views; on a fitted plane of the layout (Layout::PlaneFaceAt, within
  // kOnPlaneSpacings of the shell's spacing), only when a training frame
  // sees through it. Nothing before the first step. Returns the count.
  std::int64_t Carve(SceneEditor* fit);
  std::int64_t carved() const { return carved_; }

  // The Trainer::extra_view hook: a refinement view for this iteration,
  // chosen by (seed, iteration) alone so that a resumed run picks the same.
  const ExtraView* ViewFor(std::int64_t iteration);

  // After --resume: the refinement views of steps 1..last_step as written.
  void Reload(const SceneEditor& fit, int last_step);

  // The ablation without Gaussian refinement (the panorama results alone):
  // views at `cameras` (one trajectory, frame k at times[k]) made from the
  // panoramic representation, with the Gaussians used for geometry only.
  // Per target: the training frame nearest in time, with its warp depth
  // (options' warp_depth, as every step's warps), then the refined
  // frames of every step run (read back from StepDir) at the expansion
  // source nearest in time, each forward-warped into the target and filling
  // only what is still a hole, steps in order; what none of them reaches is
  // filled by the prior, the targets as one clip (`name`: its name in
  // messages and the prior's folders). CV_32FC3 RGB per target;
  // `note` gets the prior's note (a fallback's reason), if any. Throws
  // pano4d::Error when no step has run or a product is missing.
  std::vector<cv::Mat> PanoramicViews(SceneEditor* fit, const std::string& name,
                                      const std::vector<RasterCamera>& cameras,
                                      const std::vector<int>& times,
                                      std::string* note = nullptr);

  const std::vector<ExpandedView>& cameras() const { return all_cameras_; }
  const PanoramaFrame& frame() const { return frame_; }
  // Where step e's products go: out_dir/step_<e, two digits>.
  std::filesystem::path StepDir(int e) const;
  std::size_t refinement_views() const { return views_.size(); }

 private:
  struct Source {
    std::size_t view;  // index into the fit's views
    RasterCamera camera;
    int time;
  };
  struct StoredView {  // compact: 8-bit target
    RasterCamera camera;
    int time;
    cv::Mat target;  // CV_8UC3 RGB
    cv::Mat mask;    // CV_8UC1, 255 = M_e
  };
  struct Refined {  // step e's result per (direction, source), for chaining
    RasterCamera camera;
    cv::Mat rgb;    // CV_32FC3
    cv::Mat depth;  // CV_32FC1
  };
  void Prepare(const SceneEditor& fit);
  // Each view named after its source frame (views in ExpansionViews' order).
  void NameViews(const SceneEditor& fit,
                 std::vector<ExpandedView>* views) const;

  // The steps of RunStep. What a step warps: its views (directions x
  // sources) and per source its frame, warp depth and moving pixels.
  struct StepSources {
    std::vector<ExpandedView> views;
    std::vector<cv::Mat> rgb, depth, moving;
    Layout layout;  // fitted to the sources' static pixels
  };
  StepSources GatherSources(SceneEditor* fit, int e);
  // Direction m's clip for the prior: each source warped into its view
  // (and, chained, the previous step's result warped there into the
  // holes); the warp's own masks (before chaining) in `masks`.
  struct WarpStats {
    double hole_sum = 0, holes = 0, prefilled = 0, cracks = 0;
  };
  PriorClip WarpDirection(const StepSources& sources, int e, int m, bool chain,
                          std::vector<cv::Mat>* masks, WarpStats* stats) const;
  // Direction m's refined views kept: written under `dir` (warped, mask,
  // refined, depth), stored for L_refine and the next step, and, with
  // Gaussian refinement, the points of M_e the Gaussians do not cover yet
  // unprojected into `points`.
  struct NewPoints {
    PointCloud cloud;
    std::vector<double> depths, focals;
  };
  void KeepDirection(SceneEditor* fit, const StepSources& sources, int m,
                     const PriorClip& clip, const PriorResult& filled,
                     const std::vector<cv::Mat>& masks,
                     const std::filesystem::path& dir,
                     std::vector<Refined>* current, NewPoints* points);
  // Carving, then the new points outside seen free space as static
  // Gaussians (voxel-filtered at the step's scale).
  void AddStepGaussians(SceneEditor* fit, std::size_t step_views,
                        NewPoints* points, ExpansionStepReport* report);

  ExpansionOptions options_;
  std::uint64_t seed_;
  std::filesystem::path out_dir_;
  Prior* prior_;
  bool prepared_ = false;
  PanoramaFrame frame_;
  RasterCamera reference_;
  std::vector<Source> sources_;
  std::vector<StoredView> views_;
  // What the training frames saw, and per stored view its refined depth
  // (the warp's, and the prior's in M_e) for Carve.
  std::vector<SeenDepth> frames_seen_, expanded_seen_;
  // The layout of the sources' training depth (Prepare): the shell's faces,
  // and the planes Carve spares.
  Layout layout_;
  std::int64_t carved_ = 0;
  std::vector<ExpandedView> all_cameras_;
  int last_step_ = 0;
  std::vector<Refined> previous_;  // directions x sources, step last_step_
  ExtraView buffer_;
};

}  // namespace pano4d
