#pragma once

// What a fit did, how long each part took and why it stopped, in the manner
// of Ceres' Solver::Summary: it prints itself (BriefReport, FullReport) and
// serialises itself (ToJson: what WS/pano4d/fit.json holds).

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "evaluation/evaluate.h"
#include "src/core/workspace.h"
#include "src/gs/init.h"
#include "src/gs/trainer.h"
#include "src/pipeline/fit_options.h"

namespace pano4d {

enum class FitTermination {
  kIterationsDone,  // every iteration ran
  kTimeBudget,      // FitOptions::time_budget ran out (checkpointed)
  kStopped,         // FitController::Stop() was called (checkpointed)
  kConverged,       // the convergence stop (convergence.h) ended it
};
const char* FitTerminationName(FitTermination t);  // "iterations done", ...

// Validation PSNR / mPSNR / uPSNR over the validation frames, DyCheck's
// quantisation and plain mean over frames (frames with an empty mask left
// out): the run log's values at intervals.
struct QuickMetrics {
  std::optional<double> psnr, mpsnr, upsnr;
};

struct FitSummary {
  FitTermination termination = FitTermination::kIterationsDone;
  // The options as given and as used (ResolveFitOptions): given.depth_weight
  // unset and used.depth_weight 5 on a dataset's depth, say.
  FitOptions given, used;
  std::string depth_source;  // frames.json's, which chose the used defaults
  nlohmann::json priors;     // the learned priors used (FitInputs::priors)
  Workspace workspace;

  std::int64_t iterations = 0;  // done, in all
  // The convergence stop: signal, gate, samples [[iteration, PSNR], ...]
  // and reason (empty unless kConverged); null when it was off.
  nlohmann::json convergence;
  std::int64_t resumed_at = 0;  // 0: not resumed
  InitReport init;              // empty when resumed
  std::size_t static_gaussians = 0, dynamic_gaussians = 0;
  int motion_bases = 0;
  std::int64_t densified = 0, pruned = 0;
  std::int64_t skipped_rows = 0, skipped_steps = 0;  // non-finite

  struct Seconds {
    double total = 0, init = 0, validation = 0, expansion = 0;
    PhaseTimes trainer;
  } seconds;

  // The expansion: `expanded` when it ran; otherwise why not.
  bool expanded = false;
  std::string no_expansion_reason;
  nlohmann::json expansion_steps = nlohmann::json::array();  // step reports
  std::int64_t carved = 0;
  std::size_t refinement_views = 0;
  // The layout's shell added before the first step (none when resumed:
  // the checkpoint holds it).
  Expansion::Shell layout_shell;
  // --no-gaussian-refinement: validation scored the panorama results.
  bool panorama_only = false;
  // Which appearance transform the validation renders took (empty: the
  // trainer learns none), and, when some took a training frame's, the
  // validation PSNR of the Gaussians' own colours.
  std::string validation_appearance;
  std::optional<double> val_psnr_without_appearance;

  // The trainer's options as it ran them (densify_until resolved).
  TrainerOptions trainer_options;
  StepReport last_step;
  double train_psnr = 0.0;  // over every training frame, quantised
  std::size_t train_frames = 0, val_frames = 0;
  QuickMetrics last_validation;  // in-memory, of the last validation
  // Scored with `pano4d eval`'s code, when the frames came from a workspace
  // with validation frames.
  std::optional<EvaluationResult> evaluation;

  // One line: iterations, termination, Gaussians, train PSNR, mPSNR.
  std::string BriefReport() const;
  // The "pano4d fit report" block every fit prints.
  std::string FullReport() const;
  // fit.json: the keys scripts read (iterations, resumed_at,
  // stopped_by_time_budget, seed, static_gaussians, seconds, expansion,
  // train_psnr, options, metrics, ...) and every option given and used.
  nlohmann::json ToJson() const;
};

}  // namespace pano4d
