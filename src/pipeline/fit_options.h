#pragma once

// What a fit is asked to do. Every option of `pano4d fit` lives here or in
// the library structs it holds (the trainer's, the initialisation's, the
// expansion's), each default written once, beside its field. `fit`, `run`,
// `demo`, `expand` and the benches fill the same struct (src/cli/options.h
// maps the flags onto it) and reach training through the same controller
// (fit.h).

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "src/gs/init.h"
#include "src/gs/trainer.h"
#include "src/pano/expansion.h"

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
  // Width of the equirectangular panoramas in WS/pano4d/panorama (height
  // half of it).
  int panorama_width = 1024;

  // Defaults that depend on the input: unset, ResolveFitOptions chooses by
  // where the frames' depth came from.
  std::optional<double> depth_weight;
  std::optional<WarpDepth> warp_depth;

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

// The options a fit of frames whose depth came from `depth_source` (a
// kDepthFrom* of src/core/frames.h) runs with: depth_weight and warp_depth
// set, and copied into trainer.depth_weight and expansion.warp_depth.
//   depth weight: kGivenDepthWeight on depth the dataset gives,
//     kEstimatedDepthWeight on depth pano4d estimated (or of unknown
//     source);
//   warp depth: the frames' own depth where the dataset gives it, rendered
//     depth on estimated depth (stereo has holes and errors at the edges a
//     warp needs most; not measured there).
// Measured in docs/experiments/2026-11-23-depth-weight-5-on-dataset-depth.md
// and 2026-11-24-warp-given-depth-and-refine-outside-3.md.
FitOptions ResolveFitOptions(FitOptions given, const std::string& depth_source);

// What a resumed fit must share with the run that wrote its checkpoint:
// every option of `used` (ResolveFitOptions' result) that changes the
// result; the run's conduct (resume, checkpoint and log intervals, the time
// budget) may change.
nlohmann::json ResumeFingerprint(const FitOptions& used);

}  // namespace pano4d
