#pragma once

// What a fit is asked to do. Every option of `pano4d fit` lives here or in
// the library structs it holds (the trainer's, the initialisation's, the
// expansion's), each default written once, beside its field. `fit`, `run`,
// `demo`, `expand` and the benches fill the same struct (src/cli/options.h
// maps the flags onto it) and reach training through the same controller
// (fit.h).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "src/core/frames.h"
#include "src/gs/init.h"
#include "src/gs/trainer.h"
#include "src/pano/expansion.h"
#include "src/pano/prior.h"
#include "src/pipeline/convergence.h"

namespace pano4d {

struct FitOptions {
  // Seed of every random choice: the motion clusters, the training order,
  // the expansion's refinement views.
  std::uint64_t seed = 0;
  TrainerOptions trainer;  // its depth_weight is set from depth_weight below
  InitOptions init;        // init.num_bases = 0: every Gaussian static
  // The panoramic expansion inside the fit; false: the same fit without it,
  // the baseline of every ablation.
  bool expand = true;
  ExpansionOptions expansion;  // its warp_depth is set from warp_depth below
  // The video prior that fills the expansion's holes: a command with {in}
  // and {out} (README, "A video prior"); empty: the CPU geometry prior.
  std::string prior_cmd;
  // Seconds one clip may take in the prior command before it is stopped
  // and the CPU prior fills the clip (src/pano/prior.h).
  double prior_timeout = kPriorTimeoutSeconds;
  // Learned priors (src/datasets/priors.h): the flow and disparity of the
  // training frames, for the motion's initial tracks and the prior losses.
  // Empty: the folder the depth stage read (frames.json), if any.
  std::filesystem::path priors;
  // Width of the equirectangular panoramas in WS/pano4d/panorama (height
  // half of it).
  int panorama_width = 1024;

  // Defaults that depend on the input: unset, ResolveFitOptions chooses by
  // where the frames' depth came from and how many frames there are.
  std::optional<int> iterations;  // the schedule's length
  std::optional<double> depth_weight;
  std::optional<WarpDepth> warp_depth;
  std::optional<double> voxel_pixels;  // the initialisation's voxel
  // The convergence stop (convergence.h): unset, kAuto when `iterations`
  // is unset and kOff when it is given (a length asked for runs to its
  // end); resolved to kValidation, kTraining or kOff.
  std::optional<ConvergeOn> converge_on;
  ConvergenceOptions convergence;

  // How the run goes; none of these changes what it computes.
  bool resume = false;  // from WS/pano4d/checkpoints/fit.ckpt when there
  // No wall-clock decision: refuses time_budget. Results never depend on
  // the thread count, and a resumed run equals an uninterrupted one.
  bool deterministic = false;
  int checkpoint_every = 1000;
  int validate_every = 1000;  // quick validation metrics into the run log
  int log_every = 100;        // a run-log row
  double time_budget = 0.0;   // seconds of wall time; 0: no limit

  // Throws pano4d::Error naming the option.
  void Check() const;
  // Every option, unset ones as null.
  nlohmann::json ToJson() const;
};

// What the input-dependent defaults depend on.
struct FitInput {
  std::string depth_source;  // a kDepthFrom* of src/core/frames.h
  int train_frames = 0;
  int val_frames = 0;
};
FitInput FitInputOf(const WorkspaceFrames& frames);

// The schedule's length when --iterations is not given: kEpochs visits of
// every training frame, at least kMinIterations and at most kMaxIterations.
// Where the error-against-run-time curve flattens: Balloon1 (12 frames)
// about 1000-1250 iterations, with densification at 500-1000 (a 1200-
// iteration schedule, which densifies at 300-600, ended 0.2 dB lower); the
// small synthetic scene (48 frames) about 3000-5000
// (docs/experiments/2026-12-02-budget-and-schedule.md).
inline constexpr int kEpochs = 100;
inline constexpr int kMinIterations = 2000;
inline constexpr int kMaxIterations = 10000;
int ScheduleIterations(int train_frames);

// The initialisation's voxel, in pixels at the median depth: 2 on depth
// the dataset gives; 4 on estimated depth, whose error (stereo: 0.5-0.8%
// of the depth on Balloon1, about 2-4 pixels at its focal length) puts
// the points of one surface from different frames into different 2-pixel
// voxels, so that the count grows with the frames instead of the surface.
inline constexpr double kGivenDepthVoxelPixels = 2.0;
inline constexpr double kEstimatedDepthVoxelPixels = 4.0;

// The options a fit of `input` runs with: iterations, depth_weight,
// warp_depth and voxel_pixels set, and copied into trainer.iterations,
// trainer.depth_weight, expansion.warp_depth and init.voxel_pixels.
//   iterations: ScheduleIterations;
//   depth weight: kGivenDepthWeight on depth the dataset gives,
//     kEstimatedDepthWeight on depth pano4d estimated (or of unknown
//     source);
//   warp depth: the frames' own depth where the dataset gives it, rendered
//     depth on estimated depth (stereo has holes and errors at the edges a
//     warp needs most; not measured there);
//   voxel: kGivenDepthVoxelPixels or kEstimatedDepthVoxelPixels;
//   convergence stop: as FitOptions::converge_on says, kAuto resolved by
//     whether there are validation frames (ResolveConvergeOn).
// Measured in docs/experiments/2026-11-23-depth-weight-5-on-dataset-depth.md,
// 2026-11-24-warp-given-depth-and-refine-outside-3.md and
// 2026-12-02-budget-and-schedule.md.
FitOptions ResolveFitOptions(FitOptions given, const FitInput& input);

// What a resumed fit must share with the run that wrote its checkpoint:
// every option of `used` (ResolveFitOptions' result) that changes the
// result; the run's conduct (resume, checkpoint and log intervals, the time
// budget, the convergence stop: where it ends, not what a step computes)
// may change.
nlohmann::json ResumeFingerprint(const FitOptions& used);

}  // namespace pano4d
