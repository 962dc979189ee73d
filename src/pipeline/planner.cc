#include "src/pipeline/planner.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/frames.h"
#include "src/pipeline/depth.h"

namespace pano4d {
namespace {

std::string Percent(double fraction) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.2f%%", 100.0 * fraction);
  return buffer;
}

StageDecision Sfm(const PlanFacts& f) {
  if (!f.poses_given) {
    std::string why =
        "no poses: COLMAP estimates them from the frames (feature "
        "extraction, matching, mapping, undistortion); the run stops if it "
        "poses fewer than " +
        Percent(f.min_posed) + " of them (--min-posed)";
    if (const std::optional<double> posed = f.SfmPosedFraction()) {
      why += "; posed " + std::to_string(*f.sfm_posed) + " of " +
             std::to_string(*f.sfm_frames) + " (" + Percent(*posed) + ")";
      if (f.camera_motion == "rotation-only")
        why += " with the rotation-only camera model (the camera only turns)";
      if (f.camera_motion == "static camera")
        why += "; static camera (every frame's pose the same)";
    }
    return {"sfm", true, false, why};
  }
  if (f.input == InputKind::kDataset && f.depth_source != kDepthFromDataset) {
    return {"sfm", true, false,
            std::string("poses given, depth not: COLMAP point_triangulator "
                        "makes sparse points with the dataset's cameras, to ") +
                (f.depth_source == kDepthFromExternal
                     ? "align the --depth-dir maps to"
                     : "bound and check the stereo depth")};
  }
  return {"sfm", false, false,
          f.input == InputKind::kColmap
              ? "poses given: the COLMAP model in the workspace"
              : "poses given: the dataset's cameras"};
}

StageDecision Depth(const PlanFacts& f) {
  if (f.depth_source == kDepthFromExternal && f.camera_motion != "general") {
    return {"depth", true, false,
            "depth from --depth-dir " + f.depth_dir + ": used as given (" +
                f.camera_motion +
                ": one camera centre, no sparse points to align to)"};
  }
  if (f.depth_source == kDepthFromExternal) {
    return {"depth", true, false,
            "depth from --depth-dir " + f.depth_dir +
                ": each frame's map aligned (scale and shift) to the sparse "
                "points"};
  }
  if (f.depth_source == kDepthFromDataset) {
    return {"depth", false, false,
            "depth given: the dataset's depth maps are used as they are (the "
            "stage only lists the frames)"};
  }
  return {"depth", true, false,
          std::string(f.input == InputKind::kDataset
                          ? "not every training frame has dataset depth: "
                          : "no depth: ") +
              "plane-sweep stereo over the training frames that see the same "
              "part of the scene, on " +
              (f.input == InputKind::kDataset ? "the dataset's cameras"
                                              : "the COLMAP poses") +
              ", checked against the sparse points" +
              (f.priors_depth
                   ? "; the learned depth of --priors, aligned to the sparse "
                     "points per frame, for the moving pixels (stereo "
                     "matches frames of other times) and where stereo has "
                     "no support"
                   : "")};
}

StageDecision Motion(const PlanFacts& f) {
  if (f.no_motion) return {"motion", false, false, "left out by --no-motion"};
  if (!f.dynamic_fraction) {
    return {"motion", false, true,
            "decided after depth, from the dynamic masks"};
  }
  const std::string share =
      Percent(*f.dynamic_fraction) + " of the training pixels move";
  if (*f.dynamic_fraction < kMinDynamicFraction) {
    return {"motion", false, false,
            "no dynamic content: " + share + " (below " +
                Percent(kMinDynamicFraction) +
                "); the Gaussians get no motion parameters"};
  }
  return {"motion", true, false, share + ": motion bases for them"};
}

StageDecision Expansion(const PlanFacts& f) {
  if (f.no_expansion) {
    return {"expansion", false, false, "left out by --no-expansion"};
  }
  if (f.target_views == 0) {
    return {"expansion", true, false,
            "no target views given: the targets are the expansion's own "
            "panoramic trajectories, which leave the training coverage"};
  }
  const std::string views = std::to_string(f.target_views) + " target views";
  if (!f.unseen_fraction && f.targets_are_training_cameras) {
    return {"expansion", false, false,
            "the " + views +
                " are training cameras (seen at other times): none of their "
                "pixels lies outside the training coverage"};
  }
  if (!f.unseen_fraction) {
    return {"expansion", true, false,
            "the coverage of the " + views +
                " is unknown (no covisibility masks), so expand"};
  }
  const std::string share =
      Percent(*f.unseen_fraction) + " of the " + views + "' pixels";
  if (*f.unseen_fraction < kMinUnseenFraction) {
    return {"expansion", false, false,
            "no target view outside the training coverage: " + share +
                " unseen (below " + Percent(kMinUnseenFraction) + ")"};
  }
  return {"expansion", true, false,
          share + " were never seen by a training frame"};
}

StageDecision Eval(const PlanFacts& f) {
  if (!f.ground_truth) {
    return {"eval", false, false,
            "no ground truth: DyCheck metrics need a dataset's validation "
            "frames (held-out frames of a video get PSNR in the fit)"};
  }
  if (!f.eval_requested) {
    return {"eval", false, false,
            "not asked for (--eval); the fit still reports validation PSNR"};
  }
  return {"eval", true, false,
          "ground truth: PSNR, SSIM and LPIPS on the validation frames (and "
          "DyCheck's m* covisible, u* unseen where the dataset has "
          "covisibility masks)"};
}

}  // namespace

const char* InputKindName(InputKind kind) {
  switch (kind) {
    case InputKind::kVideo:
      return "video";
    case InputKind::kImages:
      return "images";
    case InputKind::kColmap:
      return "colmap";
    case InputKind::kDataset:
      return "dataset";
  }
  return "unknown";
}

std::optional<double> PlanFacts::SfmPosedFraction() const {
  if (!sfm_frames || !sfm_posed) return std::nullopt;
  return *sfm_posed / std::max(1.0, 1.0 * *sfm_frames);
}

const StageDecision& Plan::Get(const std::string& stage) const {
  for (const StageDecision& d : stages)
    if (d.stage == stage) return d;
  throw Error("plan", "stage", stage, "is not a stage of the plan");
}

nlohmann::json Plan::ToJson() const {
  nlohmann::json s = nlohmann::json::array();
  for (const StageDecision& d : stages) {
    s.push_back({{"stage", d.stage},
                 {"run", d.run},
                 {"pending", d.pending},
                 {"why", d.why}});
  }
  const auto optional = [](const std::optional<double>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json();
  };
  return {
      {"input",
       {{"kind", InputKindName(facts.input)}, {"path", facts.input_path}}},
      {"facts",
       {{"poses_given", facts.poses_given},
        {"depth_given", facts.depth_given},
        {"depth_dir", facts.depth_dir},
        {"depth_source", facts.depth_source},
        {"priors_dir", facts.priors_dir},
        {"priors", facts.priors},
        {"dynamic_fraction", optional(facts.dynamic_fraction)},
        {"target_views", facts.target_views},
        {"unseen_fraction", optional(facts.unseen_fraction)},
        {"targets_are_training_cameras", facts.targets_are_training_cameras},
        {"ground_truth", facts.ground_truth},
        {"sfm_frames", facts.sfm_frames ? nlohmann::json(*facts.sfm_frames)
                                        : nlohmann::json()},
        {"sfm_posed",
         facts.sfm_posed ? nlohmann::json(*facts.sfm_posed) : nlohmann::json()},
        {"sfm_posed_fraction", optional(facts.SfmPosedFraction())},
        {"min_posed", facts.min_posed},
        {"camera_motion", facts.camera_motion},
        {"eval_requested", facts.eval_requested},
        {"no_expansion", facts.no_expansion},
        {"no_motion", facts.no_motion}}},
      {"stages", s}};
}

std::string Plan::Table() const {
  std::ostringstream out;
  out << "pano4d plan (" << InputKindName(facts.input) << " "
      << facts.input_path << "):\n";
  for (const StageDecision& d : stages) {
    char head[40];
    std::snprintf(head, sizeof(head), "  %-10s %-9s", d.stage.c_str(),
                  d.pending ? "later"
                  : d.run   ? "run"
                            : "left out");
    out << head << " " << d.why << "\n";
  }
  if (!facts.priors_dir.empty()) {
    out << "  learned priors in " << facts.priors_dir << ":\n";
    for (const std::string& line : facts.priors) out << "    " << line << "\n";
  }
  return out.str();
}

Plan MakePlan(const PlanFacts& given) {
  PlanFacts facts = given;
  facts.depth_source = DepthSourceFor(facts.depth_given, facts.depth_dir);
  Plan plan;
  plan.facts = facts;
  plan.stages = {Sfm(facts),
                 Depth(facts),
                 Motion(facts),
                 {"fit", true, false,
                  "dynamic Gaussians from the frames, depth and masks"},
                 Expansion(facts),
                 Eval(facts)};
  return plan;
}

}  // namespace pano4d
