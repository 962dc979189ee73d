// pano4d fit: the dynamic 4D Gaussians fitted to the frames of
// WS/pano4d/frames.json (src/gs), with validation, the error-against-run-time
// log, atomic checkpoints and resume.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "evaluation/dataset.h"
#include "evaluation/evaluate.h"
#include "evaluation/metrics.h"
#include "evaluation/plot.h"
#include "src/cli/app.h"
#include "src/cli/expansion_outputs.h"
#include "src/cli/stages.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/median.h"
#include "src/core/npy.h"
#include "src/core/progress.h"
#include "src/core/run_recorder.h"
#include "src/core/timer.h"
#include "src/gs/init.h"
#include "src/gs/trainer.h"
#include "src/pano/expansion.h"
#include "src/pano/prior.h"
#include "src/render/rasterizer.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

// Panoramas are written at this aspect (equirectangular: 2 x 1).
constexpr int kPanoramaAspect = 2;

// The last expansion step that ran before iteration `before` (0: none).
int LastStepBefore(const ExpansionOptions& o, std::int64_t before,
                   int iterations) {
  int last = 0;
  for (std::int64_t it = o.every; it < before; it += o.every)
    for (int e : StepsDueAt(o, it, iterations)) last = std::max(last, e);
  return last;
}

struct ValidationView {
  std::string name;
  int time = 0;
  RasterCamera camera;
  Image rgb;
  cv::Mat covisible;  // empty: none
};

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
      throw Error(
          f.rgb.string(), "size",
          std::to_string(v.rgb.width()) + "x" + std::to_string(v.rgb.height()),
          "differs from its camera");
    }
    if (!f.covisible.empty()) v.covisible = ReadMask(f.covisible);
    views.push_back(std::move(v));
  }
  return views;
}

Image ToImage(const RenderOutput& out) {
  cv::Mat mat(out.height, out.width, CV_32FC3);
  std::copy(out.rgb.begin(), out.rgb.end(), mat.ptr<float>());
  return Image::FromRgb32f(mat);
}

struct QuickMetrics {
  std::optional<double> psnr, mpsnr, upsnr;
};

// PSNR, mPSNR, uPSNR over validation frames (DyCheck's quantisation and
// plain mean over frames; frames with an empty mask left out), for the run
// log at intervals. The full metrics come from `pano4d eval`'s code at the
// end.
QuickMetrics Validate(Trainer* trainer,
                      const std::vector<ValidationView>& val) {
  QuickMetrics q;
  double sums[3] = {0, 0, 0};
  int counts[3] = {0, 0, 0};
  RenderOutput out;
  for (const ValidationView& v : val) {
    trainer->Render(v.camera, v.time, &out);
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

// --no-gaussian-refinement: the validation views made from the panoramic
// representation (Expansion::PanoramicViews), one trajectory per validation
// camera (frames sharing a pose), written as renders/val/<frame>.png.
void WritePanoramaResults(Trainer* trainer, Expansion* expansion,
                          const std::vector<ValidationView>& val,
                          const fs::path& renders) {
  std::vector<std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < val.size(); ++i) {
    const RasterCamera& c = val[i].camera;
    auto same_pose = [&](const std::vector<std::size_t>& g) {
      const RasterCamera& d = val[g.front()].camera;
      return c.rotation == d.rotation && c.translation == d.translation;
    };
    auto g = std::find_if(groups.begin(), groups.end(), same_pose);
    if (g == groups.end()) {
      groups.push_back({i});
    } else {
      g->push_back(i);
    }
  }
  ProgressBar bar("panorama results", static_cast<std::int64_t>(val.size()));
  for (std::vector<std::size_t>& g : groups) {
    std::stable_sort(g.begin(), g.end(), [&](std::size_t a, std::size_t b) {
      return val[a].time < val[b].time;
    });
    std::vector<RasterCamera> cameras;
    std::vector<int> times;
    for (std::size_t i : g) {
      cameras.push_back(val[i].camera);
      times.push_back(val[i].time);
    }
    std::string note;
    const std::vector<cv::Mat> views = expansion->PanoramicViews(
        trainer, "val_" + val[g.front()].name, cameras, times, &note);
    if (!note.empty()) {
      PANO4D_LOG(kWarning) << "panorama results: " << note;
    }
    for (std::size_t k = 0; k < g.size(); ++k) {
      WriteImage(renders / (val[g[k]].name + ".png"),
                 Image::FromRgb32f(views[k].clone()));
    }
    bar.Add(static_cast<std::int64_t>(g.size()));
  }
  bar.Finish();
}

std::string Format(const std::optional<double>& v, const char* unit = "") {
  if (!v) return "n/a";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.3f%s", *v, unit);
  return buffer;
}

}  // namespace

namespace {

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

}  // namespace

double DefaultDepthWeight(const std::string& depth_source) {
  return depth_source == kDepthFromDataset ? kGivenDepthWeight
                                           : kEstimatedDepthWeight;
}

int RunFitCommand(FitCommandOptions o) {
  if (o.deterministic && o.time_budget > 0) {
    throw Error("--time-budget", "", std::to_string(o.time_budget),
                "a wall-clock budget makes the end depend on the machine; it "
                "cannot be combined with --deterministic");
  }
  if (o.checkpoint_every < 1 || o.validate_every < 1 || o.log_every < 1) {
    throw Error("--checkpoint-every/--validate-every", "", "",
                "must be at least 1");
  }
  o.trainer.seed = o.seed;
  o.init.seed = o.seed;
  if (o.no_motion) o.init.num_bases = 0;
  const fs::path ws = o.workspace;
  const fs::path ckpt = ws / "pano4d" / "checkpoints" / "fit.ckpt";
  const fs::path metrics_dir = ws / "pano4d" / "metrics";
  EnsureDirectory(ws / "pano4d" / "checkpoints");
  EnsureDirectory(metrics_dir);
  Timer total;

  const WorkspaceFrames frames = ReadWorkspaceFrames(ws);
  PANO4D_LOG(kInfo) << "fit: " << frames.train.size() << " training and "
                    << frames.val.size() << " validation frames ("
                    << frames.source << ")";
  o.trainer.depth_weight =
      o.depth_weight.value_or(DefaultDepthWeight(frames.depth_source));
  std::string why = "given";
  if (!o.depth_weight) {
    why = frames.depth_source.empty()
              ? "frames.json does not say where the depth came from; "
                "`pano4d depth` again records it"
              : "depth from " + frames.depth_source;
  }
  PANO4D_LOG(kInfo) << "fit: depth weight " << o.trainer.depth_weight << " ("
                    << why << ")";
  std::vector<TrainingView> views = LoadTrainingViews(frames.train);
  WarnIfNearThePlane(views);
  const std::vector<ValidationView> val = LoadValidation(frames.val);

  const bool resuming = o.resume && fs::exists(ckpt);
  if (o.resume && !resuming) {
    PANO4D_LOG(kInfo) << "fit: no checkpoint at " << ckpt.string()
                      << "; starting from the beginning";
  }
  Timer init_timer;
  GaussianScene scene;
  InitReport init_report;
  if (resuming) {
    scene = ReadCheckpointScene(ckpt);
  } else {
    scene = InitializeScene(views, frames.num_times, o.init, &init_report);
    PANO4D_LOG(kInfo) << init_report.Brief();
  }
  const double init_seconds = init_timer.WallSeconds();
  Trainer trainer(std::move(scene), std::move(views), o.trainer);
  std::int64_t resumed_at = 0;
  if (resuming) {
    trainer.LoadCheckpoint(ckpt);
    resumed_at = trainer.iteration();
    PANO4D_LOG(kInfo) << "fit: resumed from " << ckpt.string()
                      << " at iteration " << resumed_at;
  }

  // The expansion (issue 8): on unless --no-expansion; a run too short for
  // one expansion says so.
  const fs::path expansion_dir = ws / "pano4d" / "expansion";
  std::unique_ptr<Prior> prior;
  std::unique_ptr<Expansion> expansion;
  nlohmann::json expansion_steps = nlohmann::json::array();
  o.expansion.seed = o.seed;
  o.expansion.warp_depth = ResolveWarpDepth(o.warp_depth, frames.depth_source);
  if (!o.no_expansion) {
    o.expansion.Check();
    PANO4D_LOG(kInfo) << "fit: expansion warps with "
                      << WarpDepthName(o.expansion.warp_depth) << " depth";
    if (o.trainer.iterations <= o.expansion.every) {
      PANO4D_LOG(kInfo) << "fit: no expansion: " << o.trainer.iterations
                        << " iterations leave no room for one every "
                        << o.expansion.every << " (--expand-every)";
    } else {
      const fs::path options_path = expansion_dir / "options.json";
      nlohmann::json options_json = o.expansion.ToJson();
      options_json["prior_cmd"] = o.prior_cmd;
      if (resuming && fs::exists(options_path) &&
          ReadJson(options_path) != options_json) {
        throw Error(options_path.string(), "options", "",
                    "the checkpoint's run expanded with other options (run "
                    "with the same expansion flags, or without --resume)");
      }
      EnsureDirectory(expansion_dir);
      WriteJson(options_path, options_json);
      prior = MakePrior(o.prior_cmd, expansion_dir / "prior");
      expansion =
          std::make_unique<Expansion>(o.expansion, expansion_dir, prior.get());
      if (resuming) {
        const fs::path steps_path = expansion_dir / "steps.json";
        const int last =
            LastStepBefore(o.expansion, resumed_at, o.trainer.iterations);
        // Steps the interrupted run did after its checkpoint run again.
        if (fs::exists(steps_path)) {
          for (const auto& step : ReadJson(steps_path))
            if (GetJson<int>(step, "step", steps_path.string()) <= last)
              expansion_steps.push_back(step);
        }
        expansion->Reload(trainer, last);
      }
      trainer.extra_view = [e = expansion.get()](std::int64_t it) {
        return e->ViewFor(it);
      };
    }
  }

  const fs::path csv = metrics_dir / "fit.csv";
  RunRecorder recorder(csv, "fit",
                       {"loss", "l1", "depth_loss", "train_psnr", "gaussians",
                        "val_psnr", "val_mpsnr", "val_upsnr"},
                       resuming && fs::exists(csv));
  ProgressBar bar("fit", o.trainer.iterations);
  bar.Add(trainer.iteration());
  double validation_seconds = 0;
  double window_loss = 0, window_l1 = 0, window_depth = 0, window_psnr = 0;
  int window = 0;
  StepReport last;
  bool stopped_by_budget = false;
  double expansion_seconds = 0;
  while (!trainer.Done()) {
    if (expansion) {
      for (int e :
           StepsDueAt(o.expansion, trainer.iteration(), o.trainer.iterations)) {
        const ExpansionStepReport r = expansion->RunStep(&trainer, e);
        expansion_seconds += r.seconds;
        PANO4D_LOG(kInfo) << r.Brief();
        expansion_steps.push_back(r.ToJson());
        WriteJson(expansion_dir / "steps.json", expansion_steps);
      }
    }
    last = trainer.Step();
    if (expansion && o.expansion.carve_every > 0 &&
        trainer.iteration() % o.expansion.carve_every == 0) {
      const Timer carve;
      expansion->Carve(&trainer);
      expansion_seconds += carve.WallSeconds();
    }
    window_loss += last.loss;
    window_l1 += last.l1;
    window_depth += last.depth;
    window_psnr += last.psnr;
    ++window;
    bar.Add();
    const std::int64_t it = trainer.iteration();
    const bool validate =
        !val.empty() && (it % o.validate_every == 0 || trainer.Done());
    if (it % o.log_every == 0 || validate || trainer.Done()) {
      QuickMetrics q;
      if (validate) {
        Timer t;
        q = Validate(&trainer, val);
        validation_seconds += t.WallSeconds();
      }
      recorder.Record(it, {window_loss / window, window_l1 / window,
                           window_depth / window, window_psnr / window,
                           static_cast<double>(trainer.scene().size()), q.psnr,
                           q.mpsnr, q.upsnr});
      std::ostringstream status;
      status.precision(4);
      status << "loss " << window_loss / window << "  psnr "
             << window_psnr / window << "  " << trainer.scene().size() << " G";
      if (q.mpsnr) status << "  val m " << *q.mpsnr;
      bar.SetStatus(status.str());
      window_loss = window_l1 = window_depth = window_psnr = 0;
      window = 0;
    }
    if (it % o.checkpoint_every == 0 || trainer.Done())
      trainer.SaveCheckpoint(ckpt);
    if (o.time_budget > 0 && total.WallSeconds() > o.time_budget &&
        !trainer.Done()) {
      stopped_by_budget = true;
      trainer.SaveCheckpoint(ckpt);
      PANO4D_LOG(kInfo) << "fit: time budget of " << o.time_budget
                        << " s reached at iteration " << it;
      break;
    }
  }
  bar.Finish();
  if (expansion && !expansion->cameras().empty()) {
    WriteTrajectories(expansion_dir, expansion->cameras(), trainer.views());
    WritePanoramas(ws / "pano4d" / "panorama", trainer.scene(),
                   expansion->frame(), o.panorama_width,
                   o.panorama_width / kPanoramaAspect);
  }

  // Training-view PSNR over every training frame.
  double train_psnr = 0;
  {
    const std::vector<TrainingView>& train_views = trainer.views();
    RenderOutput out;
    for (const TrainingView& v : train_views) {
      trainer.Render(v.camera, v.time, &out);
      const cv::Mat a = QuantizeForMetrics(ToImage(out), v.name);
      cv::Mat target(v.camera.height, v.camera.width, CV_32FC3);
      std::copy(v.rgb.begin(), v.rgb.end(), target.ptr<float>());
      const cv::Mat b = QuantizeForMetrics(Image::FromRgb32f(target), v.name);
      train_psnr += Psnr(a, b).value_or(0.0);
    }
    train_psnr /= static_cast<double>(train_views.size());
  }

  // Validation renders, scored with `pano4d eval`'s code. The ablation
  // without Gaussian refinement scores the panorama results instead.
  const bool panorama_only = expansion && !o.expansion.gaussian_refinement &&
                             !expansion->cameras().empty();
  nlohmann::json metrics_json;
  std::optional<EvaluationResult> evaluation;
  if (!val.empty()) {
    const fs::path renders = ws / "pano4d" / "renders" / "val";
    const fs::path depth_renders = ws / "pano4d" / "renders" / "val_depth";
    RenderOutput out;
    for (const ValidationView& v : val) {
      trainer.Render(v.camera, v.time, &out);
      WriteNpy(depth_renders / (v.name + ".npy"),
               NpyArray::FromFloats({out.height, out.width}, out.depth));
      if (!panorama_only) WriteImage(renders / (v.name + ".png"), ToImage(out));
    }
    if (panorama_only)
      WritePanoramaResults(&trainer, expansion.get(), val, renders);
    Dataset dataset;
    dataset.root = frames.dataset.empty() ? ws : frames.dataset;
    dataset.factor = frames.dataset_factor > 0 ? frames.dataset_factor : 1;
    dataset.num_times = frames.num_times;
    for (const WorkspaceFrame& f : frames.val) {
      DatasetFrame d;
      d.id = f.name;
      d.time_id = f.time;
      d.camera = f.camera;
      d.rgb = f.rgb;
      d.covisible = f.covisible;
      dataset.val.push_back(d);
    }
    evaluation = EvaluateRenders(dataset, renders, {});
    WriteEvaluation(*evaluation, metrics_dir, PANO4D_DATASETS_META_DIR);
    metrics_json = EvaluationJson(*evaluation);
  }
  try {
    PlotRunLog(csv, metrics_dir / "fit.png",
               {"train_psnr", "val_psnr", "val_mpsnr", "val_upsnr"},
               "pano4d fit: PSNR (dB) against wall time");
  } catch (const Error& e) {
    PANO4D_LOG(kWarning) << "fit: no plot: " << e.what();
  }

  const GaussianScene& s = trainer.scene();
  const PhaseTimes& t = trainer.times();
  const double seconds = total.WallSeconds();
  nlohmann::json summary = {
      {"iterations", trainer.iteration()},
      {"resumed_at", resumed_at},
      {"stopped_by_time_budget", stopped_by_budget},
      {"deterministic", o.deterministic},
      {"seed", o.seed},
      {"static_gaussians", s.statics.size()},
      {"dynamic_gaussians", s.dynamics.size()},
      {"motion_bases", s.bases.num_bases},
      {"densified", trainer.densified_total()},
      {"pruned", trainer.pruned_total()},
      {"skipped_gaussian_updates", trainer.skipped_rows_total()},
      {"skipped_steps", trainer.skipped_steps_total()},
      {"seconds",
       {{"total", seconds},
        {"init", init_seconds},
        {"compose", t.compose},
        {"forward", t.forward},
        {"loss", t.loss},
        {"backward", t.backward},
        {"motion", t.motion},
        {"optimise", t.optimise},
        {"densify", t.densify},
        {"validation", validation_seconds},
        {"expansion", expansion_seconds}}},
      {"expansion", expansion
                        ? nlohmann::json{{"options", o.expansion.ToJson()},
                                         {"prior_cmd", o.prior_cmd},
                                         {"steps", expansion_steps},
                                         {"carved", expansion->carved()}}
                        : nlohmann::json()},
      {"final_loss", last.loss},
      {"train_psnr", train_psnr},
      {"options", trainer.options().ToJson()},
      {"metrics", metrics_json.is_null()
                      ? nlohmann::json()
                      : metrics_json.value("mean", nlohmann::json())}};
  WriteJson(ws / "pano4d" / "fit.json", summary);

  std::printf("\npano4d fit report\n");
  std::printf("  %-22s %lld", "iterations",
              static_cast<long long>(trainer.iteration()));
  if (resumed_at > 0)
    std::printf(" (resumed at %lld)", static_cast<long long>(resumed_at));
  if (stopped_by_budget) std::printf(" (stopped by the time budget)");
  std::printf("\n  %-22s static %zu, dynamic %zu, motion bases %d\n",
              "Gaussians", s.statics.size(), s.dynamics.size(),
              s.bases.num_bases);
  std::printf("  %-22s %lld densified, %lld pruned\n", "densification",
              static_cast<long long>(trainer.densified_total()),
              static_cast<long long>(trainer.pruned_total()));
  std::printf("  %-22s %lld Gaussian updates, %lld steps\n",
              "skipped (non-finite)",
              static_cast<long long>(trainer.skipped_rows_total()),
              static_cast<long long>(trainer.skipped_steps_total()));
  std::printf(
      "  %-22s %.1f s: init %.1f, forward %.1f, loss %.1f, backward %.1f, "
      "motion %.1f, optimiser %.1f, densify %.1f, compose %.1f, validation "
      "%.1f\n",
      "time", seconds, init_seconds, t.forward, t.loss, t.backward, t.motion,
      t.optimise, t.densify, t.compose, validation_seconds);
  if (expansion) {
    std::printf(
        "  %-22s %zu steps, %.1f s, %zu refinement views, %lld static "
        "Gaussians in seen free space removed%s\n",
        "expansion", expansion_steps.size(), expansion_seconds,
        expansion->refinement_views(),
        static_cast<long long>(expansion->carved()),
        panorama_only ? " (validation: the panorama results)" : "");
  } else {
    std::printf("  %-22s none (%s)\n", "expansion",
                o.no_expansion ? "--no-expansion" : "run too short");
  }
  std::printf(
      "  %-22s %.5f (L1 %.5f, SSIM %.4f, depth %.5f, normal %.5f, "
      "hidden %.5f)\n",
      "last loss", last.loss, last.l1, last.ssim, last.depth, last.normal,
      last.hidden);
  std::printf("  %-22s %.3f dB over %zu training frames\n", "train PSNR",
              train_psnr, frames.train.size());
  if (evaluation) {
    const auto value = [&](const char* key) {
      for (std::size_t i = 0; i < kNumMetrics; ++i)
        if (std::string(kMetricKeys[i]) == key) return evaluation->mean[i];
      return std::optional<double>();
    };
    std::printf(
        "  %-22s PSNR %s  SSIM %s  mPSNR %s  mSSIM %s  uPSNR %s  uSSIM %s "
        "(%zu frames)\n",
        "validation", Format(value("psnr")).c_str(),
        Format(value("ssim")).c_str(), Format(value("mpsnr")).c_str(),
        Format(value("mssim")).c_str(), Format(value("upsnr")).c_str(),
        Format(value("ussim")).c_str(), val.size());
    std::printf("  %-22s %s\n", "metrics",
                (metrics_dir / "metrics.json").c_str());
  }
  std::printf("  %-22s %s\n  %-22s %s\n", "run log", csv.c_str(), "checkpoint",
              ckpt.c_str());
  return kExitOk;
}

void AddFitCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<FitCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "fit",
      "Fit the dynamic 4D Gaussians to the frames of `pano4d depth` (CPU "
      "rasterizer, Adam, densification), with validation, a run log and "
      "checkpoints");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (WS/pano4d/frames.json from `pano4d depth`)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--iterations", o->trainer.iterations, "Training iterations")
      ->capture_default_str();
  sub->add_flag("--resume", o->resume,
                "Continue from WS/pano4d/checkpoints/fit.ckpt (same options "
                "required); without one, start from the beginning");
  sub->add_option("--seed", o->seed, "Seed of every random choice")
      ->capture_default_str();
  sub->add_flag("--deterministic", o->deterministic,
                "Guarantee that the result depends only on the inputs, "
                "options and seed: no wall-clock decision (refuses "
                "--time-budget). Results never depend on the thread count, "
                "and a resumed run equals an uninterrupted one");
  sub->add_option("--checkpoint-every", o->checkpoint_every,
                  "Write the checkpoint every N iterations (atomically)")
      ->capture_default_str();
  sub->add_option("--validate-every", o->validate_every,
                  "Validation PSNR/mPSNR/uPSNR into the run log every N "
                  "iterations")
      ->capture_default_str();
  sub->add_option("--log-every", o->log_every,
                  "A run-log row (losses, Gaussians) every N iterations")
      ->capture_default_str();
  sub->add_option("--time-budget", o->time_budget,
                  "Stop after this many seconds of wall time (0: no limit)")
      ->capture_default_str();
  sub->add_flag("--no-motion", o->no_motion,
                "Fit every Gaussian as static (no motion bases)");
  sub->add_option("--num-bases", o->init.num_bases,
                  "Motion bases K for dynamic content")
      ->capture_default_str();
  sub->add_option("--dynamic-thickness", o->init.dynamic_thickness,
                  "Moving objects start solid: each moving pixel of the "
                  "canonical frame also seeds Gaussians behind it, out to "
                  "this times the depth a round cross-section of its mask's "
                  "local width has there (0: the visible surface only)")
      ->capture_default_str();
  sub->add_option("--dynamic-layers", o->init.dynamic_layers,
                  "Gaussians seeded behind each such pixel")
      ->capture_default_str();
  sub->add_option("--max-gaussians", o->trainer.max_gaussians,
                  "Densification stops adding Gaussians at this count")
      ->capture_default_str();
  sub->add_option("--sh-degree", o->init.sh_degree,
                  "Spherical-harmonics degree of the colours (0-3)")
      ->capture_default_str();
  sub->add_option("--depth-weight", o->depth_weight,
                  "Weight of the depth loss (default: 5 on depth the dataset "
                  "gives, 1 on estimated depth: stereo or --depth-dir)");
  sub->add_option("--normal-weight", o->trainer.normal_weight,
                  "Weight of the depth-normal flatness term: Gaussians on a "
                  "surface the depth maps show become discs in it (0: off)")
      ->capture_default_str();
  sub->add_option("--hidden-weight", o->trainer.hidden_weight,
                  "Weight of the hidden-depth term: a moving object's "
                  "Gaussians may not hide deeper behind its visible surface "
                  "than --hidden-thickness (0: off)")
      ->capture_default_str();
  sub->add_option("--hidden-thickness", o->trainer.hidden_thickness,
                  "Thickness of moving objects, relative to their depth, "
                  "for the hidden-depth term")
      ->capture_default_str();
  sub->add_option("--max-static-scale-pixels",
                  o->trainer.max_static_scale_pixels,
                  "Largest scale of a static Gaussian, in pixels at the "
                  "median depth; clamped after every step (0: no clamp)")
      ->capture_default_str();
  sub->add_option("--smoothness-weight", o->trainer.smoothness_weight,
                  "Weight of the motion bases' acceleration penalty")
      ->capture_default_str();
  sub->add_flag("--no-expansion", o->no_expansion,
                "The same fit without panoramic expansion (the baseline of "
                "every ablation)");
  sub->add_option("--expand-every", o->expansion.every,
                  "An expansion every N iterations; the steps are spread "
                  "over them")
      ->capture_default_str();
  sub->add_option("--refine-weight", o->expansion.refine_weight,
                  "Weight of L_refine on the expanded views")
      ->capture_default_str();
  sub->add_option("--refine-outside-weight", o->expansion.refine_outside_weight,
                  "L_refine's weight on the warped pixels outside M_e, "
                  "relative to those in it; 0: the paper's loss, masked to "
                  "M_e (the Gaussians that fill M_e may then spread over "
                  "the warped content)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_option("--carve-every", o->expansion.carve_every,
                  "Every N iterations once an expansion step has run (and at "
                  "every step), remove the static Gaussians in known empty "
                  "space: seen through by a training frame, or seen by none "
                  "and seen through by an expanded view's warp or by most "
                  "expanded views; 0: only at the steps")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_option("--refine-every", o->expansion.refine_every,
                  "L_refine on one expanded view every N iterations")
      ->capture_default_str();
  AddExpansionFlags(sub, &o->expansion, &o->warp_depth, &o->prior_cmd,
                    &o->panorama_width);
  sub->add_flag("--one-step-expansion", o->expansion.one_step,
                "Ablation: no progressive expansion, one step at the full "
                "angle E x alpha");
  sub->add_flag(
      "--no-gaussian-refinement",
      [o](std::int64_t) { o->expansion.gaussian_refinement = false; },
      "Ablation (panorama results only): expanded views are made and "
      "written but not distilled into the Gaussians, which serve as geometry; "
      "the validation views are warped from the training frames and the "
      "refined expanded views, the rest filled by the prior");
  sub->footer(
      "Writes WS/pano4d/checkpoints/fit.ckpt, WS/pano4d/fit.json (summary), "
      "WS/pano4d/metrics/fit.csv and fit.png (error against run time), and "
      "with validation frames WS/pano4d/renders/val/ (and z-depth in "
      "renders/val_depth/<frame>.npy) and "
      "WS/pano4d/metrics/metrics.json (keys psnr, ssim, mpsnr, mssim, upsnr, "
      "ussim, ...). With expansion: WS/pano4d/expansion/ (per step and "
      "direction the warped frames, masks M_e, refined frames; "
      "trajectories.json; colmap/ with the training and expanded cameras) "
      "and WS/pano4d/panorama/ (one equirectangular PNG per time step and "
      "static.png).");
  sub->callback([action, o] { *action = [o] { return RunFitCommand(*o); }; });
}

}  // namespace pano4d::cli
