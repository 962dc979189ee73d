#include "src/pipeline/fit.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "evaluation/metrics.h"
#include "evaluation/plot.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/median.h"
#include "src/core/npy.h"
#include "src/core/progress.h"
#include "src/core/run_recorder.h"
#include "src/core/stamp.h"
#include "src/core/stop_signal.h"
#include "src/core/strings.h"
#include "src/core/timer.h"
#include "src/pano/prior.h"
#include "src/pano/trajectory_io.h"
#include "src/pipeline/eval.h"
#include "src/pipeline/expansion_outputs.h"
#include "src/pipeline/priors.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// The observer of FitObserverScope; empty without one.
FitObserver& Observer() {
  static FitObserver observer;
  return observer;
}

// The rasterizer culls what is nearer than kNearPlane (world units); a
// scene whose median depth is within this factor of it loses geometry (the
// tiny scene scaled by 1e-3 in `pano4d bench stability` learns nothing).
constexpr double kNearPlaneMargin = 100.0;

void WarnIfNearThePlane(const std::vector<TrainingView>& views) {
  std::vector<float> depths;
  for (const TrainingView& v : views)
    for (std::size_t i = 0; i < v.depth.size(); i += 97)
      if (v.depth[i] > 0) depths.push_back(v.depth[i]);
  if (depths.empty()) return;
  const double median = UpperMedian(std::move(depths));
  if (median < kNearPlaneMargin * kNearPlane) {
    PANO4D_LOG(kWarning)
        << "fit: the training depth's median is " << median
        << " world units, within " << kNearPlaneMargin
        << "x of the rasterizer's near plane " << kNearPlane
        << ": Gaussians nearer than it are not drawn. Scale the scene up "
           "(e.g. colmap model_transformer with a scale, then `pano4d depth` "
           "again)";
  }
}

std::vector<ValidationView> LoadValidation(
    const std::vector<WorkspaceFrame>& frames) {
  std::vector<ValidationView> views;
  for (const WorkspaceFrame& f : frames) {
    ValidationView v;
    v.name = f.name;
    v.time = f.time;
    v.camera = RasterCamera::FromPosed(f.camera);
    v.rgb = ReadImage(f.rgb);
    if (v.rgb.width() != v.camera.width || v.rgb.height() != v.camera.height) {
      throw Error(f.rgb.string(), "size",
                  SizeText(v.rgb.width(), v.rgb.height()),
                  "differs from its camera");
    }
    if (!f.covisible.empty()) v.covisible = ReadMask(f.covisible);
    views.push_back(std::move(v));
  }
  return views;
}

// A view of a render's colours (valid until the next render into `out`).
Image ToImage(const RenderOutput& out) {
  return Image::FromRgb32f(MatView(out.rgb, out.height, out.width, 3));
}

// Training-view PSNR over every training frame (in its own colours),
// quantised as the metrics.
double TrainPsnr(Trainer* trainer) {
  double sum = 0;
  RenderOutput out;
  for (std::size_t i = 0; i < trainer->views().size(); ++i) {
    const TrainingView& v = trainer->views()[i];
    trainer->Render(v.camera, v.time, &out, static_cast<int>(i));
    const cv::Mat a = QuantizeForMetrics(ToImage(out), v.name);
    const cv::Mat b = QuantizeForMetrics(
        Image::FromRgb32f(MatView(v.rgb, v.camera.height, v.camera.width, 3)),
        v.name);
    sum += Psnr(a, b).value_or(0.0);
  }
  return sum / static_cast<double>(trainer->views().size());
}

// The loss terms averaged over the iterations since the last log row.
struct LossWindow {
  double loss = 0, l1 = 0, depth = 0, psnr = 0;
  int steps = 0;
  void Add(const StepReport& r) {
    loss += r.loss;
    l1 += r.l1;
    depth += r.depth;
    psnr += r.psnr;
    ++steps;
  }
};

// The expansion inside the fit, with its prior and the step reports of
// steps.json.
struct ExpansionState {
  std::unique_ptr<Prior> prior;
  std::unique_ptr<Expansion> expansion;
  nlohmann::json steps = nlohmann::json::array();
};

// The expansion: on unless expand is false; a run too short for one says
// so. A resumed run reloads the steps before its checkpoint; those the
// interrupted run did after it run again.
ExpansionState StartExpansion(const Workspace& ws, const FitOptions& o,
                              bool resuming, Trainer* trainer,
                              FitSummary* summary) {
  ExpansionState ex;
  const int iterations = o.trainer.iterations;
  if (!o.expand) {
    summary->no_expansion_reason = "--no-expansion";
    return ex;
  }
  PANO4D_LOG(kInfo) << "fit: expansion warps with "
                    << WarpDepthName(o.expansion.warp_depth) << " depth";
  if (iterations <= o.expansion.every) {
    summary->no_expansion_reason = "run too short";
    PANO4D_LOG(kInfo) << "fit: no expansion: " << iterations
                      << " iterations leave no room for one every "
                      << o.expansion.every << " (--expand-every)";
    return ex;
  }
  const fs::path dir = ws.expansion();
  EnsureDirectory(dir);
  ex.prior = MakePrior(o.prior_cmd, dir / "prior", o.prior_timeout);
  ex.expansion =
      std::make_unique<Expansion>(o.expansion, o.seed, dir, ex.prior.get());
  if (resuming) {
    const fs::path steps_path = dir / "steps.json";
    const int last =
        LastStepBefore(o.expansion, summary->resumed_at, iterations);
    if (fs::exists(steps_path)) {
      for (const auto& step : ReadJson(steps_path))
        if (GetJson<int>(step, "step", steps_path.string()) <= last)
          ex.steps.push_back(step);
    }
    ex.expansion->Reload(*trainer, last);
  } else {
    // A resumed run has its shell in the checkpoint.
    summary->layout_shell = ex.expansion->AddLayoutShell(trainer);
    PANO4D_LOG(kInfo) << "fit: layout "
                      << (summary->layout_shell.planes < 0
                              ? std::string("none")
                              : std::to_string(summary->layout_shell.planes) +
                                    " plane faces, " +
                                    std::to_string(
                                        summary->layout_shell.gaussians) +
                                    " shell Gaussians where no frame saw");
  }
  trainer->extra_view = [e = ex.expansion.get()](std::int64_t it) {
    return e->ViewFor(it);
  };
  summary->expanded = true;
  return ex;
}

// Validation renders (and their depth), scored with `pano4d eval`'s code
// when the inputs came from frames.json. The ablation without Gaussian
// refinement scores the panorama results instead.
void WriteValidation(const Workspace& ws, const FitOptions& o,
                     const FitInputs& inputs, Trainer* trainer,
                     Expansion* expansion, FitSummary* summary) {
  const std::vector<ValidationView>& val = inputs.val;
  summary->panorama_only = expansion && !o.expansion.gaussian_refinement &&
                           !expansion->cameras().empty();
  if (val.empty()) return;
  RenderOutput out;
  if (std::any_of(val.begin(), val.end(), [](const ValidationView& v) {
        return v.appearance_view >= 0;
      })) {
    // Both, as the protocols allow either: the renders scored below take
    // the same camera's training transform; these keep the Gaussians' own
    // colours.
    std::vector<ValidationView> plain = val;
    for (ValidationView& v : plain) v.appearance_view = -1;
    summary->val_psnr_without_appearance = Validate(trainer, plain).psnr;
  }
  for (const ValidationView& v : val) {
    trainer->Render(v.camera, v.time, &out, v.appearance_view);
    WriteNpy(ws.val_depth_renders() / (v.name + ".npy"),
             NpyArray::FromFloats({out.height, out.width}, out.depth));
    if (!summary->panorama_only)
      WriteImage(ws.val_renders() / (v.name + ".png"), ToImage(out));
  }
  if (summary->panorama_only)
    WritePanoramaResults(trainer, expansion, val, ws.val_renders());
  if (inputs.frames) {
    summary->evaluation = EvaluateRenders(ValidationDataset(ws, *inputs.frames),
                                          ws.val_renders(), {});
    WriteEvaluation(*summary->evaluation, ws.metrics(), DatasetsMetaDir());
  }
}

// What the trainer and the expansion did, into the summary.
void Summarise(const Trainer& trainer, const ExpansionState& ex,
               FitSummary* summary) {
  const GaussianScene& s = trainer.scene();
  summary->iterations = trainer.iteration();
  summary->static_gaussians = s.statics.size();
  summary->dynamic_gaussians = s.dynamics.size();
  summary->motion_bases = s.bases.num_bases;
  summary->densified = trainer.densified_total();
  summary->pruned = trainer.pruned_total();
  summary->skipped_rows = trainer.skipped_rows_total();
  summary->skipped_steps = trainer.skipped_steps_total();
  summary->seconds.trainer = trainer.times();
  summary->trainer_options = trainer.options();
  if (ex.expansion) {
    summary->expansion_steps = ex.steps;
    summary->carved = ex.expansion->carved();
    summary->refinement_views = ex.expansion->refinement_views();
  }
}

}  // namespace

FitInputs LoadFitInputs(const Workspace& ws, const fs::path& priors) {
  FitInputs inputs;
  WorkspaceFrames frames = ReadWorkspaceFrames(ws.root());
  PANO4D_LOG(kInfo) << "fit: " << frames.train.size() << " training and "
                    << frames.val.size() << " validation frames ("
                    << frames.source << ")";
  inputs.train = LoadTrainingViews(frames.train);
  const fs::path priors_dir = priors.empty() ? frames.priors : priors;
  if (!priors_dir.empty()) {
    Tracks2D tracks;
    inputs.priors =
        AttachPriors(ScanPriors(priors_dir), PriorVideoFrames(ws, frames),
                     frames, &inputs.train, &tracks);
    if (tracks.size() > 0) inputs.tracks = std::move(tracks);
    inputs.priors["root"] = fs::absolute(priors_dir).string();
  }
  inputs.val = LoadValidation(frames.val);
  inputs.num_times = frames.num_times;
  inputs.depth_source = frames.depth_source;
  inputs.frames = std::move(frames);
  return inputs;
}

int MatchValidationCameras(const std::vector<TrainingView>& train,
                           std::vector<ValidationView>* val) {
  // Tolerances for "the same camera": the same rig camera's pose read from
  // the same file is equal to rounding.
  constexpr float kSameRotation = 1e-6f;
  constexpr float kSameCentre = 1e-6f;  // times the scene's size
  float size = 0;
  for (const TrainingView& t : train)
    size =
        std::max(size, (t.camera.Center() - train[0].camera.Center()).norm());
  size = std::max(size, 1.0f);
  int matched = 0;
  for (ValidationView& v : *val) {
    v.appearance_view = -1;
    for (std::size_t i = 0; i < train.size(); ++i) {
      const RasterCamera& a = train[i].camera;
      const RasterCamera& b = v.camera;
      if (a.width == b.width && a.height == b.height && a.fx == b.fx &&
          a.fy == b.fy && a.cx == b.cx && a.cy == b.cy &&
          (a.rotation - b.rotation).cwiseAbs().maxCoeff() <= kSameRotation &&
          (a.Center() - b.Center()).norm() <= kSameCentre * size) {
        v.appearance_view = static_cast<int>(i);
        ++matched;
        break;
      }
    }
  }
  return matched;
}

QuickMetrics Validate(Trainer* trainer,
                      const std::vector<ValidationView>& val) {
  QuickMetrics q;
  double sums[3] = {0, 0, 0};
  int counts[3] = {0, 0, 0};
  RenderOutput out;
  for (const ValidationView& v : val) {
    trainer->Render(v.camera, v.time, &out, v.appearance_view);
    const cv::Mat a = QuantizeForMetrics(ToImage(out), v.name);
    const cv::Mat b = QuantizeForMetrics(v.rgb, v.name);
    std::optional<double> values[3] = {Psnr(a, b), std::nullopt, std::nullopt};
    if (!v.covisible.empty()) {
      const cv::Mat m = MetricMask(v.covisible, v.name);
      values[1] = Psnr(a, b, m);
      values[2] = Psnr(a, b, InvertMask(m));
    }
    for (int i = 0; i < 3; ++i) {
      if (values[i] && std::isfinite(*values[i])) {
        sums[i] += *values[i];
        ++counts[i];
      }
    }
  }
  if (counts[0]) q.psnr = sums[0] / counts[0];
  if (counts[1]) q.mpsnr = sums[1] / counts[1];
  if (counts[2]) q.upsnr = sums[2] / counts[2];
  return q;
}

std::unique_ptr<Trainer> MakeFitTrainer(GaussianScene scene,
                                        std::vector<TrainingView> views,
                                        const FitOptions& used) {
  auto trainer = std::make_unique<Trainer>(std::move(scene), std::move(views),
                                           used.trainer, used.seed);
  trainer->SetFingerprint(ResumeFingerprint(used));
  return trainer;
}

FitController::FitController(Workspace workspace, FitOptions options,
                             FitInputs inputs)
    : workspace_(std::move(workspace)),
      given_(std::move(options)),
      inputs_(std::move(inputs)) {}

std::filesystem::path BackUpPreviousFit(const Workspace& ws) {
  const fs::path backup = ws.previous_fit();
  if (fs::exists(backup)) {
    throw Error::In(
        backup.string(),
        "holds the fit that an earlier `pano4d fit --force` replaced "
        "and did not complete; move it away (or delete it) first");
  }
  for (const fs::path& p :
       {ws.checkpoint().parent_path(), ws.fit_json(), ws.fit_csv(),
        ws.fit_plot(), ws.metrics_json(), ws.val_renders(),
        ws.val_depth_renders(), ws.expansion(), ws.panorama()}) {
    if (!fs::exists(p)) continue;
    const fs::path to = backup / fs::relative(p, ws.pano4d());
    fs::create_directories(to.parent_path());
    fs::rename(p, to);
  }
  return backup;
}

// How the fit's stamp and checkpoint name the training frames they were
// made on.
constexpr char kTrainingFrames[] = "the training frames";

StageRecord FitStageRecord(const Workspace& ws, const FitOptions& used,
                           const std::vector<TrainingView>& views) {
  StageRecord record(ws.root());
  const nlohmann::json options = ResumeFingerprint(used);
  for (const auto& [key, value] : options.items()) record.Option(key, value);
  record.Option("iterations", used.trainer.iterations);
  // Where the fit ends, which the resume fingerprint leaves out.
  record.Option("converge_on", ConvergeOnName(*used.converge_on));
  record.Option("convergence", used.convergence.ToJson());
  record.Content(kTrainingFrames, ViewsFingerprint(views));
  // The tracks and masks of the priors folder, which the views do not hold.
  if (!used.priors.empty()) record.File(used.priors);
  record.Output(ws.checkpoint()).Output(ws.fit_json());
  return record;
}

std::optional<std::string> CheckpointMismatch(
    const Workspace& ws, const FitOptions& used,
    const std::vector<TrainingView>& views) {
  if (!fs::exists(ws.checkpoint())) return "no checkpoint";
  const CheckpointFingerprints saved =
      ReadCheckpointFingerprints(ws.checkpoint());
  if (saved.options.is_null()) return "the checkpoint records no options";
  // The checkpoint records the options and the frames; a checkpoint
  // resumes to more iterations.
  nlohmann::json now = FitStageRecord(ws, used, views).json();
  for (const char* ends : {"iterations", "converge_on", "convergence"})
    now["options"].erase(ends);
  now.erase("files");
  return RecordDifference({{"options", saved.options},
                           {"contents", {{kTrainingFrames, saved.scene}}}},
                          now);
}

namespace {

// One fit from start to end: FitController::Run's steps.
class FitRun {
 public:
  FitRun(const Workspace& ws, const FitOptions& given, FitInputs* inputs,
         const std::atomic<bool>* stop)
      : ws_(ws),
        given_(given),
        o_(ResolveFitOptions(given, {inputs->depth_source,
                                     static_cast<int>(inputs->train.size()),
                                     static_cast<int>(inputs->val.size())})),
        inputs_(*inputs),
        stop_(*stop) {}

  FitSummary Run();

 private:
  void StartSummary();
  std::unique_ptr<Trainer> StartTrainer(bool resuming);
  void RunDueExpansions(Trainer* trainer);
  void CarveIfDue(Trainer* trainer);
  void StartConvergence(const Trainer& trainer, bool resuming);
  QuickMetrics RecordIteration(Trainer* trainer, RunRecorder* recorder,
                               ProgressBar* bar);
  bool Converged(Trainer* trainer, const QuickMetrics& validated);
  void SaveCheckpoint(Trainer* trainer);
  bool StopsEarly(Trainer* trainer, const QuickMetrics& validated);
  void WriteProducts(Trainer* trainer);

  const Workspace& ws_;
  const FitOptions& given_;
  const FitOptions o_;
  FitInputs& inputs_;
  const std::atomic<bool>& stop_;
  FitSummary summary_;
  ExpansionState ex_;
  std::optional<ConvergenceRule> rule_;
  LossWindow window_;
  Timer total_;
};

void FitRun::StartSummary() {
  summary_.given = given_;
  summary_.used = o_;
  summary_.depth_source = inputs_.depth_source;
  summary_.priors = inputs_.priors;
  summary_.workspace = ws_;
  summary_.train_frames = inputs_.train.size();
  summary_.val_frames = inputs_.val.size();
  PANO4D_LOG(kInfo) << "fit: depth weight " << o_.trainer.depth_weight << " ("
                    << (given_.depth_weight ? std::string("given")
                        : inputs_.depth_source.empty()
                            ? std::string(
                                  "frames.json does not say where the depth "
                                  "came from; `pano4d depth` again records it")
                            : "depth from " + inputs_.depth_source)
                    << ")";
  WarnIfNearThePlane(inputs_.train);
  if (o_.trainer.appearance) {
    const int matched = MatchValidationCameras(inputs_.train, &inputs_.val);
    summary_.validation_appearance =
        matched == 0
            ? "none (no validation camera is a training camera)"
            : "the same camera's training frame (" + std::to_string(matched) +
                  " of " + std::to_string(inputs_.val.size()) +
                  " validation frames)";
  }
}

// The initial scene, or the checkpoint's state when resuming.
std::unique_ptr<Trainer> FitRun::StartTrainer(bool resuming) {
  const fs::path ckpt = ws_.checkpoint();
  Timer init_timer;
  GaussianScene scene;
  if (resuming) {
    scene = ReadCheckpointScene(ckpt);
  } else {
    scene = InitializeScene(inputs_.train, inputs_.num_times, o_.init, o_.seed,
                            &summary_.init,
                            inputs_.tracks ? &*inputs_.tracks : nullptr);
    PANO4D_LOG(kInfo) << summary_.init.Brief();
  }
  summary_.seconds.init = init_timer.WallSeconds();
  std::unique_ptr<Trainer> trainer =
      MakeFitTrainer(std::move(scene), std::move(inputs_.train), o_);
  if (resuming) {
    trainer->LoadCheckpoint(ckpt);
    summary_.resumed_at = trainer->iteration();
    PANO4D_LOG(kInfo) << "fit: resumed from " << ckpt.string()
                      << " at iteration " << summary_.resumed_at;
  }
  return trainer;
}

void FitRun::RunDueExpansions(Trainer* trainer) {
  if (!ex_.expansion) return;
  for (int e :
       StepsDueAt(o_.expansion, trainer->iteration(), o_.trainer.iterations)) {
    const ExpansionStepReport r = ex_.expansion->RunStep(trainer, e);
    summary_.seconds.expansion += r.seconds;
    PANO4D_LOG(kInfo) << r.Brief();
    ex_.steps.push_back(r.ToJson());
    WriteJson(ws_.expansion() / "steps.json", ex_.steps);
  }
}

void FitRun::CarveIfDue(Trainer* trainer) {
  if (!ex_.expansion || o_.expansion.carve_every <= 0 ||
      trainer->iteration() % o_.expansion.carve_every != 0)
    return;
  const Timer carve;
  ex_.expansion->Carve(trainer);
  summary_.seconds.expansion += carve.WallSeconds();
}

// The run log's row and the progress bar's status every --log-every
// iterations, with validation every --validate-every and at the end;
// returns the validation's metrics (none when it did not validate).
QuickMetrics FitRun::RecordIteration(Trainer* trainer, RunRecorder* recorder,
                                     ProgressBar* bar) {
  const std::vector<ValidationView>& val = inputs_.val;
  const std::int64_t it = trainer->iteration();
  // A convergence sample gets a row (the plot marks a stop there), and
  // validation when the stop reads it.
  const bool sample = rule_ && rule_->Due(it);
  const bool validate =
      !val.empty() && (it % o_.validate_every == 0 || trainer->Done() ||
                       (sample && o_.converge_on == ConvergeOn::kValidation));
  if (it % o_.log_every != 0 && !validate && !trainer->Done() && !sample)
    return {};
  QuickMetrics q;
  if (validate) {
    Timer t;
    q = Validate(trainer, val);
    summary_.last_validation = q;
    summary_.seconds.validation += t.WallSeconds();
  }
  const double n = window_.steps;
  recorder->Record(
      it,
      {window_.loss / n, window_.l1 / n, window_.depth / n, window_.psnr / n,
       static_cast<double>(trainer->scene().size()), q.psnr, q.mpsnr, q.upsnr});
  std::ostringstream status;
  status.precision(4);
  status << "loss " << window_.loss / n << "  psnr " << window_.psnr / n << "  "
         << trainer->scene().size() << " G";
  if (q.mpsnr) status << "  val m " << *q.mpsnr;
  bar->SetStatus(status.str());
  window_ = {};
  return q;
}

// The convergence stop, gated after the last expansion step and the end of
// densification; a resumed run takes back the samples saved with its
// checkpoint, and one that had converged there ends at once.
void FitRun::StartConvergence(const Trainer& trainer, bool resuming) {
  if (o_.converge_on == ConvergeOn::kOff) return;
  if (o_.converge_on == ConvergeOn::kValidation && inputs_.val.empty()) {
    throw Error("--converge-on", "", "val",
                "the workspace has no validation frames to read; use train "
                "(or auto)");
  }
  const std::int64_t last_expansion =
      ex_.expansion
          ? LastExpansionIteration(o_.expansion, o_.trainer.iterations)
          : 0;
  rule_.emplace(o_.convergence,
                ConvergenceGate(last_expansion,
                                trainer.options().strategy.densify_until));
  const fs::path saved = ws_.convergence_samples();
  if (resuming && fs::exists(saved)) {
    std::vector<std::pair<std::int64_t, double>> samples;
    try {
      samples = GetJson<Json>(ReadJson(saved), "samples", saved.string())
                    .get<std::vector<std::pair<std::int64_t, double>>>();
    } catch (const nlohmann::json::exception& e) {
      throw Error(saved.string(), "samples", "",
                  std::string("not a list of [iteration, PSNR] pairs (") +
                      e.what() + "); delete it to resume without them");
    }
    rule_->Restore(samples, trainer.iteration());
    if (!rule_->reason().empty())
      summary_.termination = FitTermination::kConverged;
  }
}

// Whether the convergence stop ends the fit at this iteration, whose
// validation (if any) is `validated`.
bool FitRun::Converged(Trainer* trainer, const QuickMetrics& validated) {
  const std::int64_t it = trainer->iteration();
  if (!rule_ || !rule_->Due(it) || trainer->Done()) return false;
  std::optional<double> psnr;
  if (o_.converge_on == ConvergeOn::kTraining) {
    const Timer t;
    psnr = TrainPsnr(trainer);
    summary_.seconds.validation += t.WallSeconds();
  } else {
    psnr = validated.psnr;
  }
  if (!psnr) return false;
  const std::optional<std::string> reason = rule_->Add(it, *psnr);
  if (!reason) return false;
  summary_.termination = FitTermination::kConverged;
  PANO4D_LOG(kInfo) << "fit: converged at iteration " << it << ": "
                    << ConvergeOnName(*o_.converge_on) << " " << *reason;
  return true;
}

// The trainer's checkpoint and the convergence samples up to it.
void FitRun::SaveCheckpoint(Trainer* trainer) {
  trainer->SaveCheckpoint(ws_.checkpoint());
  if (rule_)
    WriteJson(ws_.convergence_samples(), {{"samples", rule_->samples()}});
}

// Checkpoints every --checkpoint-every iterations and at the end; true
// when the fit ends here (done, converged, the time budget spent, or a
// stop asked).
bool FitRun::StopsEarly(Trainer* trainer, const QuickMetrics& validated) {
  const fs::path ckpt = ws_.checkpoint();
  const std::int64_t it = trainer->iteration();
  const bool converged = Converged(trainer, validated);
  if (it % o_.checkpoint_every == 0 || trainer->Done() || converged)
    SaveCheckpoint(trainer);
  if (trainer->Done() || converged) return true;
  if (o_.time_budget > 0 && total_.WallSeconds() > o_.time_budget) {
    summary_.termination = FitTermination::kTimeBudget;
    SaveCheckpoint(trainer);
    PANO4D_LOG(kInfo) << "fit: time budget of " << o_.time_budget
                      << " s reached at iteration " << it;
    return true;
  }
  if (stop_.load() || StopRequested()) {
    summary_.termination = FitTermination::kStopped;
    SaveCheckpoint(trainer);
    PANO4D_LOG(kInfo) << "fit: stopped at iteration " << it
                      << (StopRequested() ? " on request (signal)" : "")
                      << "; checkpoint " << ckpt.string();
    return true;
  }
  return false;
}

// The trajectories and panoramas of the expansion, the validation renders
// and metrics, the plot, fit.json and, for a fit that ran every iteration,
// its stamp.
void FitRun::WriteProducts(Trainer* trainer) {
  if (ex_.expansion && !ex_.expansion->cameras().empty()) {
    WriteTrajectories(ws_.expansion(), ex_.expansion->cameras(),
                      SourceCamerasOf(trainer->views()));
    WritePanoramas(ws_.panorama(), trainer->scene(), ex_.expansion->frame(),
                   o_.panorama_width, o_.panorama_width / kPanoramaAspect);
  }
  summary_.train_psnr = TrainPsnr(trainer);
  WriteValidation(ws_, o_, inputs_, trainer, ex_.expansion.get(), &summary_);
  try {
    std::vector<std::pair<std::int64_t, std::string>> marks;
    if (summary_.termination == FitTermination::kConverged) {
      marks.emplace_back(
          trainer->iteration(),
          "converged at " + std::to_string(trainer->iteration()));
    }
    PlotRunLog(ws_.fit_csv(), ws_.fit_plot(),
               {"train_psnr", "val_psnr", "val_mpsnr", "val_upsnr"},
               "pano4d fit: PSNR (dB) against wall time", marks);
  } catch (const Error& e) {
    PANO4D_LOG(kWarning) << "fit: no plot: " << e.what();
  }
  Summarise(*trainer, ex_, &summary_);
  if (rule_) {
    summary_.convergence = {{"signal", ConvergeOnName(*o_.converge_on)},
                            {"gate", rule_->gate()},
                            {"samples", rule_->samples()},
                            {"reason", rule_->reason()}};
  }
  summary_.seconds.total = total_.WallSeconds();
  WriteJson(ws_.fit_json(), summary_.ToJson());
  if (summary_.termination == FitTermination::kIterationsDone ||
      summary_.termination == FitTermination::kConverged) {
    StageStamp(ws_, "fit")
        .Write(FitStageRecord(ws_, o_, trainer->views()),
               summary_.seconds.total);
  }
}

FitSummary FitRun::Run() {
  StageStamp(ws_, "fit").Remove();
  EnsureDirectory(ws_.checkpoint().parent_path());
  EnsureDirectory(ws_.metrics());
  StartSummary();
  const fs::path ckpt = ws_.checkpoint();
  const bool resuming = o_.resume && fs::exists(ckpt);
  if (o_.resume && !resuming) {
    PANO4D_LOG(kInfo) << "fit: no checkpoint at " << ckpt.string()
                      << "; starting from the beginning";
  }
  const std::unique_ptr<Trainer> trainer = StartTrainer(resuming);
  ex_ = StartExpansion(ws_, o_, resuming, trainer.get(), &summary_);
  StartConvergence(*trainer, resuming);
  RunRecorder recorder(ws_.fit_csv(), "fit",
                       {"loss", "l1", "depth_loss", "train_psnr", "gaussians",
                        "val_psnr", "val_mpsnr", "val_upsnr"},
                       resuming && fs::exists(ws_.fit_csv()));
  ProgressBar bar("fit", o_.trainer.iterations);
  bar.Add(trainer->iteration());
  while (!trainer->Done() &&
         summary_.termination != FitTermination::kConverged) {
    RunDueExpansions(trainer.get());
    summary_.last_step = trainer->Step();
    CarveIfDue(trainer.get());
    window_.Add(summary_.last_step);
    bar.Add();
    const QuickMetrics validated =
        RecordIteration(trainer.get(), &recorder, &bar);
    if (Observer()) {
      Observer()({trainer->iteration(), o_.trainer.iterations,
                  summary_.last_step.loss, summary_.last_step.psnr,
                  trainer->scene().size(), validated});
    }
    if (StopsEarly(trainer.get(), validated)) break;
  }
  bar.Finish();
  if (StopRequested()) {
    // Stopped before a time limit: the checkpoint is what counts; the
    // renders and fit.json come when the same command resumes.
    Summarise(*trainer, ex_, &summary_);
    summary_.seconds.total = total_.WallSeconds();
    return summary_;
  }
  WriteProducts(trainer.get());
  return summary_;
}

}  // namespace

FitObserverScope::FitObserverScope(FitObserver observer) {
  if (Observer()) {
    throw Error::In("pano4d",
                    "another stage is running in this process (one at a "
                    "time)");
  }
  Observer() = std::move(observer);
}
FitObserverScope::~FitObserverScope() { Observer() = nullptr; }

FitSummary FitController::Run() {
  given_.Check();
  return FitRun(workspace_, given_, &inputs_, &stop_).Run();
}

FitSummary RunFit(const Workspace& workspace, const FitOptions& options) {
  options.Check();
  return FitController(workspace, options,
                       LoadFitInputs(workspace, options.priors))
      .Run();
}

}  // namespace pano4d
