#pragma once

// The stage planner of `pano4d run`: from what the input already has, which
// stages run and which are left out, and why (DESIGN.md, "What a user does").
// The plan is pure data; `pano4d run` gathers the facts, prints the plan,
// writes it to WS/pano4d/plan.json and runs it.

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace pano4d {

enum class InputKind { kVideo, kImages, kColmap, kDataset };
const char* InputKindName(InputKind kind);

// The default of --min-posed: a fit of fewer posed frames than this share
// of a video is a fit of another, shorter video, and users found out only
// from the results (issue 36: 12 of 145 frames fitted in silence).
constexpr double kDefaultMinPosed = 0.8;
// What is known about the input. Facts a stage finds out later (the dynamic
// masks come from `sfm` or `depth`) are empty until then; the plan says
// when they will be decided.
struct PlanFacts {
  InputKind input = InputKind::kVideo;
  std::string input_path;
  bool poses_given = false;  // a COLMAP workspace or a dataset's cameras
  bool depth_given = false;  // a dataset with depth maps for every frame
  std::string depth_dir;     // --depth-dir: another tool's depth maps
  // --priors: learned priors; each layout found, with its use or why it is
  // not used (DescribePriorUse), and whether they hold depth.
  std::string priors_dir;
  std::vector<std::string> priors;
  bool priors_depth = false;
  // Where the training depth will come from: kDepthFrom* (frames.h), as
  // DepthSourceFor (depth.h) chooses it from the two above; MakePlan fills
  // it in.
  std::string depth_source;
  // Fraction of training pixels the dynamic masks mark as moving.
  std::optional<double> dynamic_fraction;
  // Target views: the validation cameras, when the input has them. The
  // fraction of their pixels that no training frame saw (empty: no target
  // views given, the expansion's own trajectories are the targets).
  int target_views = 0;
  std::optional<double> unseen_fraction;
  // Every target view has the pose and intrinsics of a training frame (the
  // Nvidia protocol tests view 0, which trains at time 0): then nothing of
  // theirs lies outside the training coverage, masks or not.
  bool targets_are_training_cameras = false;
  bool ground_truth = false;  // validation frames with images
  // After sfm: the frames COLMAP was given and those it posed (empty
  // before, and when the poses are given).
  std::optional<int> sfm_frames, sfm_posed;
  // sfm_posed / sfm_frames, empty before sfm.
  std::optional<double> SfmPosedFraction() const;
  // sfm's camera model: "general", or one centre and no points:
  // "rotation-only" (a pan) or "static camera" (SfmReport::CameraMotion).
  std::string camera_motion = "general";
  // `pano4d run` stops after sfm below this share of frames posed.
  double min_posed = kDefaultMinPosed;
  // The user's word, which overrides the facts.
  bool eval_requested = false;
  bool no_expansion = false;
  bool no_motion = false;
};

// Below this fraction of moving training pixels a scene is static: a few
// mis-segmented pixels do not pay for K motion bases per Gaussian.
constexpr double kMinDynamicFraction = 0.001;
// Below this fraction of unseen target pixels there is nothing for the
// expansion to synthesise that the metrics (or a viewer) would notice.
constexpr double kMinUnseenFraction = 0.005;

struct StageDecision {
  std::string stage;  // sfm, depth, motion, fit, expansion, eval
  bool run = false;
  bool pending = false;  // decided after an earlier stage (why says which)
  std::string why;
};

struct Plan {
  PlanFacts facts;
  std::vector<StageDecision> stages;

  // Throws pano4d::Error for a stage the plan does not have.
  const StageDecision& Get(const std::string& stage) const;
  bool Runs(const std::string& stage) const { return Get(stage).run; }
  nlohmann::json ToJson() const;
  std::string Table() const;  // one line per stage, for the terminal
};

// The stages in order: sfm, depth, motion, fit, expansion, eval.
Plan MakePlan(const PlanFacts& facts);

}  // namespace pano4d
