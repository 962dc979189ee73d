#include "src/pipeline/run.h"

#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <ostream>
#include <string>

#include <opencv2/core.hpp>

#include "colmap_ext/colmap_runner.h"
#include "colmap_ext/model.h"
#include "evaluation/lpips.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/stamp.h"
#include "src/core/stop_signal.h"
#include "src/core/strings.h"
#include "src/core/timer.h"
#include "src/datasets/dataset.h"
#include "src/pipeline/depth.h"
#include "src/pipeline/eval.h"
#include "src/pipeline/fit.h"
#include "src/pipeline/priors.h"
#include "src/pipeline/sfm.h"

namespace pano4d {
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

// Two cameras closer than this (rotation in radians, centres relative to
// their distance from the origin plus one) are the same camera: a dataset's
// poses are stored to float precision or better.
constexpr double kSameCameraTolerance = 1e-6;

// Whether every validation frame is seen from a training frame's camera.
bool ValidationCamerasAreTraining(const Dataset& dataset) {
  if (dataset.val.empty()) return false;
  for (const DatasetFrame& v : dataset.val) {
    const Eigen::Vector3d cv = CameraCenter(v.camera.cam_from_world);
    bool found = false;
    for (const DatasetFrame& t : dataset.train) {
      const Eigen::Vector3d ct = CameraCenter(t.camera.cam_from_world);
      found = t.camera.camera.params == v.camera.camera.params &&
              t.camera.camera.width == v.camera.camera.width &&
              t.camera.camera.height == v.camera.camera.height &&
              v.camera.cam_from_world.rotation.angularDistance(
                  t.camera.cam_from_world.rotation) < kSameCameraTolerance &&
              (cv - ct).norm() < kSameCameraTolerance * (1 + cv.norm());
      if (found) break;
    }
    if (!found) return false;
  }
  return true;
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
void AdoptColmapWorkspace(const Workspace& ws) {
  if (fs::exists(ws.sfm_json())) return;
  const std::vector<std::pair<fs::path, fs::path>> layouts = {
      {"dense/sparse", "dense/images"},
      {"sparse/0", "images"},
      {"sparse", "images"}};
  for (const auto& [model, images] : layouts) {
    if (DetectModelFormat(ws.root() / model) &&
        fs::is_directory(ws.root() / images)) {
      EnsureDirectory(ws.pano4d());
      WriteJson(ws.sfm_json(), {{"model", model.string()},
                                {"images", images.string()},
                                {"source", "pano4d run --colmap"}});
      return;
    }
  }
  throw Error(ws.root().string(), "COLMAP model", "",
              "no model with its images found (looked for dense/sparse with "
              "dense/images, sparse/0 or sparse with images); run COLMAP's "
              "mapper and image_undistorter, or `pano4d run --video`");
}

// A stage's status in plan.json when an earlier run's outputs are reused.
constexpr char kReused[] = "complete from an earlier run";
constexpr char kNothingChanged[] = "nothing it read changed";

struct StageResult {
  std::string status;
  std::string why;  // what changed, or why nothing needs to run
};

// What would stop a stage of the plan half way, checked before the first:
// the colmap executable and its version for sfm, the LPIPS weights for eval, a
// depth map per training frame in --depth-dir (for a COLMAP model the frames
// are known only after sfm; then only the folder is checked).
void CheckPlanCanRun(const RunOptions& o, const Plan& plan) {
  if (plan.Runs("sfm"))
    ColmapRunner(o.sfm.colmap).Version(Workspace(o.workspace).logs());
  if (plan.Runs("eval") && !o.lpips_weights.empty())
    Lpips::Load(o.lpips_weights);
  if (o.depth.depth_dir.empty()) return;
  std::vector<std::string> names;
  if (!o.dataset.empty()) {
    for (const DatasetFrame& f : LoadDataset(o.dataset, o.depth.factor).train)
      names.push_back(f.id);
  }
  ExternalDepthFiles(o.depth.depth_dir, names);
}

void WritePlan(const Workspace& ws, const RunOptions& o, const Plan& plan,
               const nlohmann::json& results) {
  nlohmann::json j = plan.ToJson();
  j["options"] = o.ToJson();
  j["results"] = results;
  WriteJson(ws.plan_json(), j);
}

}  // namespace

std::string RunSummary::BriefReport() const {
  return StringPrintf("done in %.1f s; the report is %s", seconds,
                      (report.dir / "index.md").c_str());
}

nlohmann::json RunOptions::ToJson() const {
  return {{"colmap", colmap.string()},
          {"dataset", dataset.string()},
          {"workspace", workspace.string()},
          {"eval", eval},
          {"lpips_weights", lpips_weights.string()},
          {"sfm", sfm.ToJson()},
          {"min_posed", min_posed},
          {"depth", depth.ToJson()},
          {"fit", fit.ToJson()}};
}

PlanFacts GatherFacts(const RunOptions& o) {
  PlanFacts f;
  f.eval_requested = o.eval;
  f.no_expansion = !o.fit.expand;
  f.no_motion = o.fit.init.num_bases == 0;
  if (!o.dataset.empty()) {
    f.input = InputKind::kDataset;
    f.input_path = o.dataset.string();
    const Dataset d = LoadDataset(o.dataset, o.depth.factor);
    f.poses_given = true;
    f.depth_given = HasDepth(d);
    f.target_views = static_cast<int>(d.val.size());
    f.ground_truth = !d.val.empty();
    f.unseen_fraction = UnseenFraction(d);
    f.targets_are_training_cameras = ValidationCamerasAreTraining(d);
  } else if (!o.colmap.empty()) {
    f.input = InputKind::kColmap;
    f.input_path = o.colmap.string();
    f.poses_given = true;
  } else {
    const SfmOptions& s = o.sfm;
    f.input = s.video.empty() ? InputKind::kImages : InputKind::kVideo;
    f.input_path = (s.video.empty() ? s.images : s.video).string();
  }
  f.depth_dir = o.depth.depth_dir.string();
  if (!o.depth.priors.empty()) {
    // Read now: a folder without a known layout stops the run before sfm.
    const PriorsFolder priors = ScanPriors(o.depth.priors);
    f.priors_dir = o.depth.priors.string();
    f.priors_depth = !priors.Of(PriorKind::kDepth).empty() &&
                     f.depth_dir.empty() && !f.depth_given;
    f.priors =
        DescribePriorUse(priors, !f.depth_dir.empty() ? "--depth-dir's maps"
                                 : f.depth_given ? "the dataset's depth maps"
                                                 : "");
  }
  f.min_posed = o.min_posed;
  // A workspace that an earlier run took through sfm or depth already
  // knows.
  const Workspace ws(o.workspace);
  if (!f.poses_given && fs::exists(ws.sfm_json())) {
    const nlohmann::json d =
        ReadJson(ws.sfm_json()).value("diagnosis", nlohmann::json());
    if (d.is_object() && d.contains("frames") && d.contains("posed")) {
      f.sfm_frames = d["frames"].get<int>();
      f.sfm_posed = d["posed"].get<int>();
    }
  }
  if (fs::exists(ws.frames_json()))
    f.dynamic_fraction = DynamicFraction(ReadWorkspaceFrames(ws.root()));
  return f;
}

namespace {

// `given` checked, with its defaults: the COLMAP workspace as the
// workspace, and one factor for every stage (the protocol's, unless given).
RunOptions ResolveRunOptions(const RunOptions& given) {
  RunOptions o = given;
  if (o.workspace.empty()) o.workspace = o.colmap;
  const int inputs = !o.sfm.video.empty() + !o.sfm.images.empty() +
                     !o.colmap.empty() + !o.dataset.empty();
  if (inputs != 1) {
    throw Error("pano4d run", "input", std::to_string(inputs) + " given",
                "give exactly one of --video, --images, --colmap, --dataset");
  }
  if (o.workspace.empty()) {
    throw Error("--workspace", "", "",
                "required (except with --colmap, whose folder is the "
                "workspace)");
  }
  if (!o.colmap.empty() &&
      fs::weakly_canonical(o.colmap) != fs::weakly_canonical(o.workspace)) {
    throw Error("--colmap", "", o.colmap.string(),
                "the COLMAP workspace is the workspace: leave --workspace "
                "out or give the same folder");
  }
  o.fit.Check();
  o.depth.Check();
  if (!(o.min_posed >= 0 && o.min_posed <= 1)) {
    throw Error("pano4d run", "--min-posed", std::to_string(o.min_posed),
                "expected a share of the frames between 0 and 1");
  }
  if (!o.dataset.empty())
    o.depth.factor = LoadDataset(o.dataset, o.depth.factor).factor;
  return o;
}

// One run of the plan: RunPipeline's stages, each recorded in plan.json
// with its status, why it ran or was reused, and its seconds.
class Pipeline {
 public:
  Pipeline(RunOptions o, std::ostream* progress)
      : o_(std::move(o)), ws_(o_.workspace), progress_(progress) {
    EnsureDirectory(ws_.pano4d());
    RemoveLeftoverTemporaries(ws_.root());
    if (!o_.colmap.empty()) AdoptColmapWorkspace(ws_);
    facts_ = GatherFacts(o_);
    plan_ = MakePlan(facts_);
    if (progress_) *progress_ << plan_.Table() << std::flush;
    CheckPlanCanRun(o_, plan_);
    summary_.stages = nlohmann::json::object();
    WritePlan(ws_, o_, plan_, summary_.stages);
  }

  void SfmStage();
  void CheckPoses();
  void DepthStage();
  void MotionDecision();
  void FitStage();
  void EvalStage();
  RunSummary Finish();

 private:
  void Stage(const std::string& name, const std::function<StageResult()>& body);
  // Ends the run after sfm, its status in plan.json.
  [[noreturn]] void StopAfterSfm(const std::string& status, Error error);

  const RunOptions o_;
  const Workspace ws_;
  std::ostream* progress_;
  PlanFacts facts_;
  Plan plan_;
  RunSummary summary_;
  Timer total_;
  std::optional<SfmDiagnosis> posed_;
  WorkspaceFrames frames_;  // depth's, read once it ran
  std::string camera_motion_ = "general";
};

void Pipeline::Stage(const std::string& name,
                     const std::function<StageResult()>& body) {
  Timer t;
  const StageResult r = body();
  summary_.stages[name] = {
      {"status", r.status}, {"why", r.why}, {"seconds", t.WallSeconds()}};
  WritePlan(ws_, o_, plan_, summary_.stages);
  PANO4D_LOG(kInfo) << "run: " << name << ": " << r.status
                    << (r.why.empty() ? "" : " (" + r.why + ")") << ", "
                    << t.WallSeconds() << " s";
}

void Pipeline::SfmStage() {
  if (!plan_.Runs("sfm")) return;
  Stage("sfm", [&] {
    SfmStageOptions s;
    s.sfm = o_.sfm;
    s.sfm.workspace = ws_.root();
    s.dataset = o_.dataset;
    s.factor = o_.depth.factor;
    const SfmStageSummary r = RunSfmStage(s);
    if (progress_) *progress_ << r.FullReport();
    posed_ = r.report.diagnosis;
    camera_motion_ = r.report.CameraMotion();
    std::string ran;
    for (const SfmStepReport& step : r.report.steps)
      if (!step.skipped) ran += (ran.empty() ? "" : ", ") + step.step;
    return ran.empty() ? StageResult{kReused, kNothingChanged}
                       : StageResult{"done", "ran " + ran};
  });
}

void Pipeline::StopAfterSfm(const std::string& status, Error error) {
  summary_.stages["sfm"]["status"] = status;
  WritePlan(ws_, o_, plan_, summary_.stages);
  throw error;
}

// Estimated poses: the share posed is a fact of the plan, and below
// --min-posed the end of the run; so is a camera with one centre without
// depth maps given.
void Pipeline::CheckPoses() {
  if (!posed_ || facts_.poses_given) return;
  const SfmDiagnosis& posed = *posed_;
  facts_.sfm_frames = posed.frames;
  facts_.sfm_posed = posed.posed;
  facts_.camera_motion = camera_motion_;
  plan_ = MakePlan(facts_);
  WritePlan(ws_, o_, plan_, summary_.stages);
  if (posed.PosedFraction() < o_.min_posed) {
    StopAfterSfm(
        "too few frames posed",
        Error("pano4d run", "sfm",
              StringPrintf("%d of %d frames posed (%.1f%%)", posed.posed,
                           posed.frames, 100 * posed.PosedFraction()),
              StringPrintf("below --min-posed %.0f%%, so the fit would see a "
                           "fraction of the video. Cause: %s. To try: %s; or "
                           "--min-posed %.2f to fit the posed frames anyway "
                           "(details: %s)",
                           100 * o_.min_posed, posed.Cause().c_str(),
                           posed.Remedy().c_str(),
                           std::floor(100 * posed.PosedFraction()) / 100,
                           ws_.sfm_json().c_str())));
  }
  // One centre: no stereo baseline and no points to align depth to, so
  // the depth must be the user's, taken as it is.
  if (camera_motion_ != "general" && o_.depth.depth_dir.empty()) {
    StopAfterSfm(
        camera_motion_,
        Error("pano4d run", "sfm", camera_motion_,
              (camera_motion_ == "static camera"
                   ? std::string("the camera stands still")
                   : std::string("the camera only turns")) +
                  ": sfm posed the frames with one centre (" +
                  (ws_.sparse() / "0").string() +
                  ", no sparse points), so plane-sweep stereo has no "
                  "baseline; give depth maps with --depth-dir (one per "
                  "frame, metric: they are used as they are)"));
  }
}

// Reused while its stamp records the same inputs.
void Pipeline::DepthStage() {
  Stage("depth", [&] {
    DepthOptions d = o_.depth;
    d.dataset = o_.dataset;
    const std::optional<std::string> stale =
        StageStamp(ws_, "depth").Decide(DepthStageRecord(ws_, d));
    if (!stale) return StageResult{kReused, kNothingChanged};
    const DepthSummary r = RunDepth(ws_, d);
    PANO4D_LOG(kInfo) << "depth: " << r.BriefReport();
    std::string why = *stale;
    // Partial or failed learned depth: which frames, in the plan's results.
    if (!d.priors.empty()) why += "; " + r.BriefReport();
    return StageResult{plan_.Runs("depth") ? "estimated" : "listed", why};
  });
}

// The dynamic masks exist now: the motion decision.
void Pipeline::MotionDecision() {
  frames_ = ReadWorkspaceFrames(ws_.root());
  facts_.dynamic_fraction = DynamicFraction(frames_);
  plan_ = MakePlan(facts_);
  PANO4D_LOG(kInfo) << "run: motion: " << plan_.Get("motion").why;
  WritePlan(ws_, o_, plan_, summary_.stages);
}

// Reused while its stamp records the same; else resumed from a checkpoint
// made with the same options on the same frames, or started afresh.
void Pipeline::FitStage() {
  Stage("fit", [&] {
    FitOptions f = o_.fit;
    f.priors = o_.depth.priors;
    if (!plan_.Runs("motion")) f.init.num_bases = 0;
    if (!plan_.Runs("expansion")) f.expand = false;
    const FitOptions used = ResolveFitOptions(f, FitInputOf(frames_));
    FitInputs inputs = LoadFitInputs(ws_, f.priors);
    const std::optional<std::string> stale =
        StageStamp(ws_, "fit").Decide(FitStageRecord(ws_, used, inputs.train));
    if (!stale) return StageResult{kReused, kNothingChanged};
    const std::optional<std::string> mismatch =
        CheckpointMismatch(ws_, used, inputs.train);
    if (mismatch && fs::exists(ws_.checkpoint())) {
      PANO4D_LOG(kInfo) << "run: fit: the workspace's fit is not this one's ("
                        << *mismatch << "); its products are removed and the "
                        << "fit starts from the beginning";
      // Else a fit that stops early would leave them to be taken for its
      // own: the old checkpoint resumed, the old fit.json read as complete.
      for (const fs::path& p : {ws_.checkpoint().parent_path(), ws_.fit_json(),
                                ws_.expansion(), ws_.panorama()})
        fs::remove_all(p);
    }
    f.resume = !mismatch;
    f.Check();
    const FitSummary r = FitController(ws_, f, std::move(inputs)).Run();
    if (StopRequested()) {
      throw Error::In(
          "fit", "stopped on request (signal " + std::to_string(StopSignal()) +
                     "); its checkpoint " + ws_.checkpoint().string() +
                     " is kept: run the same command again to "
                     "resume");
    }
    if (progress_) *progress_ << r.FullReport() << std::flush;
    return StageResult{"done", mismatch ? *stale : "resumed its checkpoint"};
  });
}

void Pipeline::EvalStage() {
  if (!plan_.Runs("eval")) return;
  Stage("eval", [&] {
    EvalOptions e;
    e.dataset = o_.dataset;
    e.renders = ws_.val_renders();
    e.out = ws_.metrics();
    e.factor = o_.depth.factor;
    e.lpips_weights = o_.lpips_weights;
    const EvalSummary r = RunEval(e);
    if (progress_) {
      *progress_ << r.markdown << "\nwritten to " << r.out.string()
                 << ": metrics.json, metrics.md, per_frame.csv\n";
    }
    return StageResult{"done", ""};
  });
}

// The report, written last, and the run's summary.
RunSummary Pipeline::Finish() {
  summary_.report = WriteReport(ws_);
  summary_.plan = plan_;
  summary_.seconds = total_.WallSeconds();
  if (progress_) {
    *progress_ << StringPrintf(
                      "pano4d run: done in %.1f s; plan and stage times in "
                      "%s, the report in %s\n",
                      summary_.seconds, ws_.plan_json().c_str(),
                      (summary_.report.dir / "index.md").c_str())
               << std::flush;
  }
  return summary_;
}

}  // namespace

RunSummary RunPipeline(const RunOptions& given, std::ostream* progress) {
  Pipeline run(ResolveRunOptions(given), progress);
  run.SfmStage();
  run.CheckPoses();
  run.DepthStage();
  run.MotionDecision();
  run.FitStage();
  run.EvalStage();
  return run.Finish();
}

}  // namespace pano4d
