#pragma once

// The fit stage: the dynamic 4D Gaussians fitted to a workspace's frames,
// with the expansion inside (src/pano), validation at intervals, the
// error-against-run-time log, atomic checkpoints, resume and a time budget.
// `pano4d fit`, `run`, `demo`, `bench budget` and `bench stability` all
// train through FitController; `pano4d expand` makes its trainer with the
// same options and function (MakeFitTrainer).

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/stamp.h"
#include "src/core/workspace.h"
#include "src/gs/trainer.h"
#include "src/pipeline/fit_options.h"
#include "src/pipeline/fit_summary.h"

namespace pano4d {

// A validation frame in memory: ground truth and, when the dataset has
// one, its covisibility mask (0/255).
struct ValidationView {
  std::string name;
  int time = 0;
  RasterCamera camera;
  Image rgb;
  cv::Mat covisible;  // empty: none
  // The training view taken by the same camera (Nvidia's view 0 trains at
  // t = 0): renders take its appearance transform, the colours that camera
  // records. -1: none, the Gaussians' own colours.
  int appearance_view = -1;
};

// Sets each validation view's appearance_view: the first training view
// whose camera has the same intrinsics and pose (centre within 1e-6 of the
// scene's size, rotation within 1e-6), else -1. Returns how many match.
int MatchValidationCameras(const std::vector<TrainingView>& train,
                           std::vector<ValidationView>* val);

// What a fit works on.
struct FitInputs {
  std::vector<TrainingView> train;
  std::vector<ValidationView> val;
  int num_times = 0;
  std::string depth_source;  // a kDepthFrom*: chooses the used defaults
  // frames.json, when the inputs came from it: the final validation renders
  // are then scored with `pano4d eval`'s code against its dataset.
  std::optional<WorkspaceFrames> frames;
  // The learned priors attached to the training views (AttachPriors'
  // report; null without priors), and their 2D tracks over the times.
  nlohmann::json priors;
  std::optional<Tracks2D> tracks;
};

// The inputs of WS/pano4d/frames.json, with the flow and disparity of
// `priors` (empty: the folder frames.json names, if any). Throws
// pano4d::Error naming a missing or mismatched file (and `pano4d depth`
// when frames.json is missing).
FitInputs LoadFitInputs(const Workspace& workspace,
                        const std::filesystem::path& priors = {});

// The trainer of a fit with `used` options (ResolveFitOptions' result) on
// `views`, starting from `scene`, its resume fingerprint set: the
// controller's, and `pano4d expand`'s on a checkpoint's Gaussians.
std::unique_ptr<Trainer> MakeFitTrainer(GaussianScene scene,
                                        std::vector<TrainingView> views,
                                        const FitOptions& used);

// Renders `views` with `trainer` and scores them (QuickMetrics).
QuickMetrics Validate(Trainer* trainer,
                      const std::vector<ValidationView>& views);

class FitController {
 public:
  // Fits `inputs` with `options` (as given; resolved by ResolveFitOptions
  // against inputs.depth_source), writing into `workspace`.
  FitController(Workspace workspace, FitOptions options, FitInputs inputs);

  // Runs to the end, the time budget or Stop(), checkpointing on the way,
  // and writes fit.json, the run log and its plot, the validation renders
  // and metrics, and the expansion's products. Throws pano4d::Error on bad
  // input or when a checkpoint to resume from does not match the options.
  // Call it once: the training views move into the trainer.
  FitSummary Run();

  // Asks a running Run() to checkpoint and return after the current
  // iteration (termination kStopped). Safe from another thread or a signal
  // handler.
  void Stop() { stop_.store(true); }

 private:
  Workspace workspace_;
  FitOptions given_;
  FitInputs inputs_;
  std::atomic<bool> stop_{false};
};

// One iteration of a running fit, as a progress observer sees it.
struct FitProgress {
  std::int64_t iteration = 0, iterations = 0;  // done, scheduled
  double loss = 0, train_psnr = 0;             // this iteration's
  std::size_t gaussians = 0;
  QuickMetrics validation;  // set on the iterations that validated
};
// Called by every fit in this process after each iteration, on the fit's
// thread, while a FitObserverScope lives (one at a time): what embeds the
// library (the Python module) shows progress and asks to stop through it
// (RequestStop, stop_signal.h). Nothing the fit computes depends on it.
// A second scope while one lives throws pano4d::Error.
using FitObserver = std::function<void(const FitProgress&)>;
class FitObserverScope {
 public:
  explicit FitObserverScope(FitObserver observer);
  ~FitObserverScope();
  FitObserverScope(const FitObserverScope&) = delete;
  FitObserverScope& operator=(const FitObserverScope&) = delete;
};

// LoadFitInputs and FitController::Run in one call.
FitSummary RunFit(const Workspace& workspace, const FitOptions& options);

// `pano4d fit --force` on a workspace that holds a fit: moves what a fit
// writes (checkpoints, fit.json, fit.csv and fit.png, metrics.json, the
// validation renders, expansion/ and panorama/, those that exist) to
// WS/pano4d/previous_fit/ under the same names, so that nothing is lost
// if the new fit fails; the caller removes it once the new fit completed.
// Returns that folder. Throws pano4d::Error naming it when it exists
// already (the backup of an earlier --force run that did not complete).
std::filesystem::path BackUpPreviousFit(const Workspace& workspace);

// What a fit with `used` options (ResolveFitOptions' result) on `views`
// runs with and reads (its options, ViewsFingerprint of the frames, the
// priors folder) and writes, for its stamp (src/core/stamp.h): written when
// every iteration ran, it lets `pano4d run` reuse the fit.
StageRecord FitStageRecord(const Workspace& workspace, const FitOptions& used,
                           const std::vector<TrainingView>& views);

// Whether WS/pano4d/checkpoints/fit.ckpt was written by a fit with these
// (used) options on the frames `views`, compared as RecordDifference
// compares stamps (a checkpoint resumes to more iterations): the reason it
// was not, or nothing when it was.
std::optional<std::string> CheckpointMismatch(
    const Workspace& workspace, const FitOptions& used,
    const std::vector<TrainingView>& views);

}  // namespace pano4d
