#include "src/pipeline/fit_options.h"

#include <algorithm>
#include <cmath>

#include "src/core/error.h"
#include "src/core/frames.h"

namespace pano4d {

void FitOptions::Check() const {
  if (deterministic && time_budget > 0) {
    throw Error("--time-budget", "", std::to_string(time_budget),
                "a wall-clock budget makes the end depend on the machine; it "
                "cannot be combined with --deterministic");
  }
  if (!(prior_timeout > 0) || !std::isfinite(prior_timeout)) {
    throw Error("--prior-timeout", "", std::to_string(prior_timeout),
                "must be a positive number of seconds");
  }
  if (!(time_budget >= 0)) {
    throw Error("--time-budget", "", std::to_string(time_budget),
                "must be 0 (no limit) or positive");
  }
  if (checkpoint_every < 1 || validate_every < 1 || log_every < 1) {
    throw Error("--checkpoint-every/--validate-every/--log-every", "", "",
                "must be at least 1");
  }
  if (iterations && *iterations < 1) {
    throw Error("--iterations", "", std::to_string(*iterations),
                "must be at least 1");
  }
  if (voxel_pixels && !(*voxel_pixels > 0)) {
    throw Error("--voxel-pixels", "", std::to_string(*voxel_pixels),
                "must be positive");
  }
  // As TrainerOptions::Check's bound on loss weights, before frames load.
  if (depth_weight &&
      !(*depth_weight >= 0 && *depth_weight <= kMaxLossWeight)) {
    throw Error("--depth-weight", "depth_weight", std::to_string(*depth_weight),
                "must be from 0 to 10000 (the photometric term's weight is "
                "1)");
  }
  if (panorama_width < 2) {
    throw Error("--panorama-width", "", std::to_string(panorama_width),
                "must be at least 2");
  }
  if (converge_on != ConvergeOn::kOff) convergence.Check();
  trainer.Check();
  init.Check();
  if (expand) expansion.Check();
}

nlohmann::json FitOptions::ToJson() const {
  // The input-dependent defaults appear as given: null until resolved.
  const auto optional = [](const auto& v) {
    return v ? nlohmann::json(*v) : nlohmann::json();
  };
  nlohmann::json trainer_json = trainer.ToJson();
  trainer_json["iterations"] = optional(iterations);
  trainer_json["depth_weight"] = optional(depth_weight);
  nlohmann::json init_json = init.ToJson();
  init_json["voxel_pixels"] = optional(voxel_pixels);
  nlohmann::json expansion_json = expansion.ToJson();
  expansion_json["warp_depth"] =
      warp_depth ? nlohmann::json(WarpDepthName(*warp_depth))
                 : nlohmann::json();
  return {
      {"seed", seed},
      {"trainer", trainer_json},
      {"init", init_json},
      {"expand", expand},
      {"expansion", expansion_json},
      {"prior_cmd", prior_cmd},
      {"prior_timeout", prior_timeout},
      {"priors", priors.string()},
      {"panorama_width", panorama_width},
      {"iterations", optional(iterations)},
      {"depth_weight", optional(depth_weight)},
      {"warp_depth", expansion_json["warp_depth"]},
      {"voxel_pixels", optional(voxel_pixels)},
      {"converge_on", converge_on ? nlohmann::json(ConvergeOnName(*converge_on))
                                  : nlohmann::json()},
      {"convergence", convergence.ToJson()},
      {"resume", resume},
      {"deterministic", deterministic},
      {"checkpoint_every", checkpoint_every},
      {"validate_every", validate_every},
      {"log_every", log_every},
      {"time_budget", time_budget}};
}

FitInput FitInputOf(const WorkspaceFrames& frames) {
  return {frames.depth_source, static_cast<int>(frames.train.size()),
          static_cast<int>(frames.val.size())};
}

int ScheduleIterations(int train_frames) {
  return std::clamp(kEpochs * train_frames, kMinIterations, kMaxIterations);
}

FitOptions ResolveFitOptions(FitOptions o, const FitInput& input) {
  const bool dataset_depth = input.depth_source == kDepthFromDataset;
  if (!o.converge_on)
    o.converge_on = o.iterations ? ConvergeOn::kOff : ConvergeOn::kAuto;
  o.converge_on = ResolveConvergeOn(*o.converge_on, input.val_frames > 0);
  if (!o.iterations) o.iterations = ScheduleIterations(input.train_frames);
  if (!o.voxel_pixels) {
    o.voxel_pixels =
        dataset_depth ? kGivenDepthVoxelPixels : kEstimatedDepthVoxelPixels;
  }
  o.trainer.iterations = *o.iterations;
  o.init.voxel_pixels = *o.voxel_pixels;
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
        "log_every", "time_budget", "converge_on", "convergence",
        "panorama_width", "prior_timeout",
        // What the priors hold is in the views' fingerprint, not where.
        "priors"})
    j.erase(conduct);
  // Held in trainer, init and expansion as used.
  j.erase("iterations");
  j.erase("depth_weight");
  j.erase("warp_depth");
  j.erase("voxel_pixels");
  if (!used.expand) {
    j.erase("expansion");
    j.erase("prior_cmd");
  }
  return j;
}

}  // namespace pano4d
