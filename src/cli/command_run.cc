// pano4d run: the stage planner decides which stages a given input needs,
// prints the plan, writes WS/pano4d/plan.json and runs it; every stage
// resumes from what an earlier run left in the workspace.
#include "src/cli/run.h"

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "colmap_ext/model.h"
#include "evaluation/dataset.h"
#include "src/cli/app.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/timer.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

// A covisibility mask marks a pixel seen by the training frames when it is
// at least this bright (DyCheck writes 0 and 255).
constexpr int kCovisibleLevel = 128;

// The fraction of the validation pixels that no training frame saw, from
// the dataset's covisibility masks (empty when a frame has none).
std::optional<double> UnseenFraction(const Dataset& dataset) {
  if (dataset.val.empty()) return std::nullopt;
  double unseen = 0, total = 0;
  for (const DatasetFrame& f : dataset.val) {
    if (f.covisible.empty() || !fs::exists(f.covisible)) return std::nullopt;
    const cv::Mat m = ReadMask(f.covisible);
    unseen +=
        static_cast<double>(m.total()) - cv::countNonZero(m >= kCovisibleLevel);
    total += static_cast<double>(m.total());
  }
  return unseen / total;
}

// The fraction of training pixels the dynamic masks of frames.json mark as
// moving (frames without a mask count as static).
double DynamicFraction(const WorkspaceFrames& frames) {
  double moving = 0, total = 0;
  for (const WorkspaceFrame& f : frames.train) {
    const double pixels =
        static_cast<double>(f.camera.camera.width) * f.camera.camera.height;
    total += pixels;
    if (f.dynamic_mask.empty()) continue;
    const cv::Mat m = ReadMask(f.dynamic_mask);
    moving += cv::countNonZero(m);
  }
  return total > 0 ? moving / total : 0.0;
}

// A COLMAP workspace that `pano4d sfm` did not write: its model and images
// are found (COLMAP's undistorted output first, since pano4d fits pinhole
// cameras) and recorded in WS/pano4d/sfm.json for the later stages.
void AdoptColmapWorkspace(const fs::path& ws) {
  const fs::path sfm_json = ws / "pano4d" / "sfm.json";
  if (fs::exists(sfm_json)) return;
  const std::vector<std::pair<fs::path, fs::path>> layouts = {
      {"dense/sparse", "dense/images"},
      {"sparse/0", "images"},
      {"sparse", "images"}};
  for (const auto& [model, images] : layouts) {
    if (DetectModelFormat(ws / model) && fs::is_directory(ws / images)) {
      EnsureDirectory(ws / "pano4d");
      WriteJson(sfm_json, {{"model", model.string()},
                           {"images", images.string()},
                           {"source", "pano4d run --colmap"}});
      return;
    }
  }
  throw Error(ws.string(), "COLMAP model", "",
              "no model with its images found (looked for dense/sparse with "
              "dense/images, sparse/0 or sparse with images); run COLMAP's "
              "mapper and image_undistorter, or `pano4d run --video`");
}

// What a fit in the workspace was asked for: a later run with other
// options fits again from the start instead of resuming or reusing it.
nlohmann::json FitFingerprint(const FitCommandOptions& f) {
  return {{"iterations", f.trainer.iterations},
          {"seed", f.seed},
          {"no_motion", f.no_motion},
          {"no_expansion", f.no_expansion},
          {"expansion", f.expansion.ToJson()},
          {"warp_depth", f.warp_depth},
          {"prior_cmd", f.prior_cmd}};
}

// Whether fit.json says a fit of `iterations` finished.
bool FitComplete(const fs::path& ws, int iterations) {
  const fs::path path = ws / "pano4d" / "fit.json";
  if (!fs::exists(path)) return false;
  const nlohmann::json j = ReadJson(path);
  return j.value("iterations", 0) >= iterations &&
         !j.value("stopped_by_time_budget", false);
}

// Whether frames.json was listed from this input: a dataset at the same
// path and factor, or (video, images, COLMAP) any, since `pano4d depth`
// writes it last.
bool FramesFromThisInput(const fs::path& ws, const RunCommandOptions& o) {
  if (!fs::exists(FramesPath(ws))) return false;
  const WorkspaceFrames frames = ReadWorkspaceFrames(ws);
  if (o.dataset.empty()) return true;
  return frames.dataset_factor == o.factor &&
         fs::weakly_canonical(frames.dataset) ==
             fs::weakly_canonical(o.dataset);
}

struct StageLog {
  nlohmann::json entries = nlohmann::json::object();
  void Record(const std::string& stage, const std::string& status,
              double seconds) {
    entries[stage] = {{"status", status}, {"seconds", seconds}};
  }
};

void WritePlan(const fs::path& ws, const Plan& plan, const StageLog& log) {
  nlohmann::json j = plan.ToJson();
  j["results"] = log.entries;
  WriteJson(ws / "pano4d" / "plan.json", j);
}

}  // namespace

PlanFacts GatherFacts(const RunCommandOptions& o) {
  PlanFacts f;
  f.eval_requested = o.eval;
  f.no_expansion = o.fit.no_expansion;
  f.no_motion = o.fit.no_motion;
  if (!o.dataset.empty()) {
    f.input = InputKind::kDataset;
    f.input_path = o.dataset.string();
    const Dataset d = LoadDataset(o.dataset, o.factor);
    f.poses_given = true;
    f.depth_given = !d.train.empty();
    for (const DatasetFrame& frame : d.train)
      f.depth_given = f.depth_given && !frame.depth.empty();
    f.target_views = static_cast<int>(d.val.size());
    f.ground_truth = !d.val.empty();
    f.unseen_fraction = UnseenFraction(d);
  } else if (!o.colmap.empty()) {
    f.input = InputKind::kColmap;
    f.input_path = o.colmap.string();
    f.poses_given = true;
  } else {
    f.input = o.video.empty() ? InputKind::kImages : InputKind::kVideo;
    f.input_path = (o.video.empty() ? o.images : o.video).string();
  }
  // A workspace that an earlier run took through depth already knows.
  if (fs::exists(FramesPath(o.workspace)))
    f.dynamic_fraction = DynamicFraction(ReadWorkspaceFrames(o.workspace));
  return f;
}

int RunPipeline(const RunCommandOptions& o, RunReport* report) {
  const int inputs = !o.video.empty() + !o.images.empty() + !o.colmap.empty() +
                     !o.dataset.empty();
  if (inputs != 1) {
    throw Error("pano4d run", "input", std::to_string(inputs) + " given",
                "give exactly one of --video, --images, --colmap, --dataset");
  }
  const fs::path ws = o.workspace;
  EnsureDirectory(ws / "pano4d");
  if (!o.colmap.empty()) AdoptColmapWorkspace(ws);
  PlanFacts facts = GatherFacts(o);
  Plan plan = MakePlan(facts);
  std::cout << plan.Table() << std::flush;
  if (!o.dataset.empty() && plan.Runs("depth")) {
    throw Error(o.dataset.string(), "depth", "",
                "the dataset has no depth for every training frame, and `run` "
                "estimates depth only on its own COLMAP workspaces: run "
                "`pano4d sfm --dataset D --workspace WS`, then `pano4d run "
                "--colmap WS`");
  }
  StageLog log;
  WritePlan(ws, plan, log);
  Timer total;

  const auto stage = [&](const std::string& name, const auto& body) {
    Timer t;
    const std::string status = body();
    log.Record(name, status, t.WallSeconds());
    WritePlan(ws, plan, log);
    PANO4D_LOG(kInfo) << "run: " << name << ": " << status << " ("
                      << t.WallSeconds() << " s)";
  };

  if (plan.Runs("sfm")) {
    stage("sfm", [&] {
      SfmCommandOptions s;
      s.sfm.workspace = ws;
      s.sfm.video = o.video;
      s.sfm.images = o.images;
      s.sfm.max_size = o.max_size;
      s.dataset = o.dataset.string();
      RunSfmCommand(s);
      return std::string("done");
    });
  }
  stage("depth", [&] {
    if (FramesFromThisInput(ws, o))
      return std::string("complete from an earlier run");
    DepthCommandOptions d;
    d.workspace = ws;
    d.factor = o.factor;
    d.holdout = o.holdout;
    d.dataset = o.dataset;
    RunDepthCommand(d);
    return std::string(plan.Runs("depth") ? "estimated" : "listed");
  });

  // The dynamic masks exist now: the motion decision.
  facts.dynamic_fraction = DynamicFraction(ReadWorkspaceFrames(ws));
  plan = MakePlan(facts);
  PANO4D_LOG(kInfo) << "run: motion: " << plan.Get("motion").why;
  WritePlan(ws, plan, log);

  stage("fit", [&] {
    FitCommandOptions f = o.fit;
    f.workspace = ws;
    f.no_motion = !plan.Runs("motion");
    f.no_expansion = !plan.Runs("expansion");
    const fs::path stamp = ws / "pano4d" / "run_fit.json";
    const bool same = fs::exists(stamp) && ReadJson(stamp) == FitFingerprint(f);
    if (same && FitComplete(ws, f.trainer.iterations))
      return std::string("complete from an earlier run");
    if (!same && fs::exists(stamp)) {
      PANO4D_LOG(kInfo) << "run: fit: the workspace's fit had other options ("
                        << stamp.string() << "); fitting from the start";
      // Its expansion products would otherwise be reported as this fit's.
      fs::remove_all(ws / "pano4d" / "expansion");
      fs::remove_all(ws / "pano4d" / "panorama");
    }
    WriteJson(stamp, FitFingerprint(f));
    f.resume = same;
    RunFitCommand(f);
    return std::string("done");
  });

  if (plan.Runs("eval")) {
    stage("eval", [&] {
      EvalOptions e;
      e.dataset = o.dataset.string();
      e.renders = (ws / "pano4d" / "renders" / "val").string();
      e.out = (ws / "pano4d" / "metrics").string();
      e.factor = o.factor;
      RunEval(e);
      return std::string("done");
    });
  }
  const ReportSummary summary = WriteReport(ws);
  if (report) {
    report->plan = plan;
    report->stages = log.entries;
    report->seconds = total.WallSeconds();
    report->report = summary;
  }
  std::printf(
      "pano4d run: done in %.1f s; plan and stage times in %s, the report "
      "in %s\n",
      total.WallSeconds(), (ws / "pano4d" / "plan.json").c_str(),
      (summary.dir / "index.md").c_str());
  return kExitOk;
}

void AddRunCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<RunCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "run",
      "Plan and run every stage on a video, images, COLMAP workspace or "
      "dataset: the plan says which stages run, which are left out and why");
  auto* input = sub->add_option_group("input", "exactly one of");
  input
      ->add_option("--video", o->video, "A video file (COLMAP estimates poses)")
      ->check(CLI::ExistingFile);
  input->add_option("--images", o->images, "A folder of frames, in order")
      ->check(CLI::ExistingDirectory);
  input
      ->add_option("--colmap", o->colmap,
                   "A COLMAP workspace with a model (poses given); it is "
                   "also the workspace unless --workspace says otherwise")
      ->check(CLI::ExistingDirectory);
  input
      ->add_option("--dataset", o->dataset,
                   "A dataset (DyCheck iPhone, Nvidia, Kubric-4D, synth): "
                   "poses, depth and validation frames given")
      ->check(CLI::ExistingDirectory);
  input->require_option(1);
  sub->add_option("--workspace", o->workspace, "The workspace (created)");
  sub->add_flag("--eval", o->eval,
                "Evaluate the validation renders (DyCheck metrics) when the "
                "input has ground truth");
  sub->add_option("--iterations", o->fit.trainer.iterations, "Fit iterations")
      ->capture_default_str();
  sub->add_option("--expand-every", o->fit.expansion.every,
                  "An expansion every N iterations")
      ->capture_default_str();
  sub->add_option("--validate-every", o->fit.validate_every,
                  "Validation metrics into the run log every N iterations")
      ->capture_default_str();
  sub->add_option("--seed", o->fit.seed, "Seed of every random choice")
      ->capture_default_str();
  sub->add_option("--factor", o->factor,
                  "Resolution divisor of a dataset's frames")
      ->capture_default_str();
  sub->add_option("--holdout", o->holdout,
                  "Video or images: hold out every N-th frame for "
                  "validation PSNR (0: none)")
      ->capture_default_str();
  sub->add_option("--max-size", o->max_size,
                  "Video or images: resize the frames to this longest side "
                  "in pixels before SfM (0: as they are)")
      ->capture_default_str();
  sub->add_flag("--no-expansion", o->fit.no_expansion,
                "Leave the panoramic expansion out");
  sub->add_flag("--no-motion", o->fit.no_motion,
                "Fit every Gaussian as static");
  sub->add_option("--prior-cmd", o->fit.prior_cmd,
                  "External prior command 'CMD {in} {out}' (see `pano4d fit "
                  "--help`); default: the CPU geometry prior");
  sub->footer(
      "Writes WS/pano4d/plan.json (the plan, the facts it was made from, and "
      "per stage its status and seconds), what each stage writes (see "
      "`pano4d sfm|depth|fit|eval --help`), and WS/report/index.md (as "
      "`pano4d demo`). Run it again to resume.");
  sub->callback([action, o] {
    *action = [o] {
      RunCommandOptions r = *o;
      if (r.workspace.empty()) {
        if (r.colmap.empty()) {
          throw Error("--workspace", "", "",
                      "required (except with --colmap, whose folder is the "
                      "workspace)");
        }
        r.workspace = r.colmap;
      }
      if (!r.colmap.empty() &&
          fs::weakly_canonical(r.colmap) != fs::weakly_canonical(r.workspace)) {
        throw Error("--colmap", "", r.colmap.string(),
                    "the COLMAP workspace is the workspace: leave "
                    "--workspace out or give the same folder");
      }
      return RunPipeline(r, nullptr);
    };
  });
}

}  // namespace pano4d::cli
