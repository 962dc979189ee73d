#include "src/pipeline/fit_options.h"

#include "src/core/error.h"
#include "src/core/frames.h"

namespace pano4d {

void FitOptions::Check() const {
  if (deterministic && time_budget > 0) {
    throw Error("--time-budget", "", std::to_string(time_budget),
                "a wall-clock budget makes the end depend on the machine; it "
                "cannot be combined with --deterministic");
  }
  if (!(time_budget >= 0)) {
    throw Error("--time-budget", "", std::to_string(time_budget),
                "must be 0 (no limit) or positive");
  }
  if (checkpoint_every < 1 || validate_every < 1 || log_every < 1) {
    throw Error("--checkpoint-every/--validate-every/--log-every", "", "",
                "must be at least 1");
  }
  if (depth_weight && !(*depth_weight >= 0)) {
    throw Error("--depth-weight", "", std::to_string(*depth_weight),
                "must be zero or positive");
  }
  if (panorama_width < 2) {
    throw Error("--panorama-width", "", std::to_string(panorama_width),
                "must be at least 2");
  }
  trainer.Check();
  init.Check();
  if (expand) expansion.Check();
}

nlohmann::json FitOptions::ToJson() const {
  // The input-dependent defaults appear as given: null until resolved.
  nlohmann::json trainer_json = trainer.ToJson();
  trainer_json["depth_weight"] =
      depth_weight ? nlohmann::json(*depth_weight) : nlohmann::json();
  nlohmann::json expansion_json = expansion.ToJson();
  expansion_json["warp_depth"] =
      warp_depth ? nlohmann::json(WarpDepthName(*warp_depth))
                 : nlohmann::json();
  return {{"seed", seed},
          {"trainer", trainer_json},
          {"init", init.ToJson()},
          {"expand", expand},
          {"expansion", expansion_json},
          {"prior_cmd", prior_cmd},
          {"panorama_width", panorama_width},
          {"depth_weight",
           depth_weight ? nlohmann::json(*depth_weight) : nlohmann::json()},
          {"warp_depth", expansion_json["warp_depth"]},
          {"resume", resume},
          {"deterministic", deterministic},
          {"checkpoint_every", checkpoint_every},
          {"validate_every", validate_every},
          {"log_every", log_every},
          {"time_budget", time_budget}};
}

FitOptions ResolveFitOptions(FitOptions o, const std::string& depth_source) {
  const bool dataset_depth = depth_source == kDepthFromDataset;
  if (!o.depth_weight)
    o.depth_weight = dataset_depth ? kGivenDepthWeight : kEstimatedDepthWeight;
  if (!o.warp_depth)
    o.warp_depth = dataset_depth ? WarpDepth::kGiven : WarpDepth::kRendered;
  o.trainer.depth_weight = *o.depth_weight;
  o.expansion.warp_depth = *o.warp_depth;
  return o;
}

nlohmann::json ResumeFingerprint(const FitOptions& used) {
  nlohmann::json j = used.ToJson();
  for (const char* conduct :
       {"resume", "deterministic", "checkpoint_every", "validate_every",
        "log_every", "time_budget", "panorama_width"})
    j.erase(conduct);
  // Held in trainer and expansion as used.
  j.erase("depth_weight");
  j.erase("warp_depth");
  if (!used.expand) {
    j.erase("expansion");
    j.erase("prior_cmd");
  }
  return j;
}

}  // namespace pano4d
