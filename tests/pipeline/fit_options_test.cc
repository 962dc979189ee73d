#include "src/pipeline/fit_options.h"

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/frames.h"
#include "src/core/json.h"

namespace pano4d {
namespace {

// Depth the dataset gives is trusted more than depth pano4d estimated, and
// warped with; a frames.json from before the source was stored counts as
// estimated. A value given is used as it is.
TEST(FitOptionsTest, InputDependentDefaultsFollowTheDepthSource) {
  const FitOptions given;
  const FitOptions dataset = ResolveFitOptions(given, {kDepthFromDataset});
  EXPECT_EQ(dataset.trainer.depth_weight, kGivenDepthWeight);
  EXPECT_EQ(dataset.expansion.warp_depth, WarpDepth::kGiven);
  for (const char* estimated : {kDepthFromStereo, kDepthFromExternal, ""}) {
    const FitOptions used = ResolveFitOptions(given, {estimated});
    EXPECT_EQ(used.trainer.depth_weight, kEstimatedDepthWeight) << estimated;
    EXPECT_EQ(used.expansion.warp_depth, WarpDepth::kRendered) << estimated;
  }
  EXPECT_GT(kGivenDepthWeight, kEstimatedDepthWeight);
  FitOptions set;
  set.depth_weight = 2.5;
  set.warp_depth = WarpDepth::kRendered;
  const FitOptions used = ResolveFitOptions(set, {kDepthFromDataset});
  EXPECT_EQ(used.trainer.depth_weight, 2.5);
  EXPECT_EQ(used.expansion.warp_depth, WarpDepth::kRendered);
  // Given and used, as fit.json records them.
  EXPECT_TRUE(given.ToJson().at("depth_weight").is_null());
  EXPECT_TRUE(given.ToJson().at("warp_depth").is_null());
  EXPECT_EQ(dataset.ToJson().at("depth_weight"), kGivenDepthWeight);
  EXPECT_EQ(dataset.ToJson().at("warp_depth"), "given");
}

// The schedule and the initial voxel follow the input: 100 visits of every
// frame within [2000, 10000]; a 4-pixel voxel on estimated depth, whose
// error would scatter one surface over many 2-pixel voxels. Given values
// stay.
TEST(FitOptionsTest, ScheduleAndVoxelFollowTheInput) {
  EXPECT_EQ(ResolveFitOptions({}, {kDepthFromStereo, 30}).trainer.iterations,
            3000);
  EXPECT_EQ(ResolveFitOptions({}, {kDepthFromDataset, 48}).trainer.iterations,
            4800);
  EXPECT_EQ(ResolveFitOptions({}, {kDepthFromDataset, 3}).trainer.iterations,
            kMinIterations);
  EXPECT_EQ(ResolveFitOptions({}, {kDepthFromDataset, 500}).trainer.iterations,
            kMaxIterations);
  EXPECT_EQ(ResolveFitOptions({}, {kDepthFromDataset, 12}).init.voxel_pixels,
            kGivenDepthVoxelPixels);
  EXPECT_EQ(ResolveFitOptions({}, {kDepthFromStereo, 12}).init.voxel_pixels,
            kEstimatedDepthVoxelPixels);
  FitOptions given;
  given.iterations = 77;
  given.voxel_pixels = 3;
  const FitOptions used = ResolveFitOptions(given, {kDepthFromStereo, 12});
  EXPECT_EQ(used.trainer.iterations, 77);
  EXPECT_EQ(used.init.voxel_pixels, 3);
  EXPECT_TRUE(FitOptions{}.ToJson().at("iterations").is_null());
  EXPECT_EQ(used.ToJson().at("iterations"), 77);
  EXPECT_THROW(
      [] {
        FitOptions bad;
        bad.iterations = 0;
        bad.Check();
      }(),
      Error);
}

// Every option of every struct is in the JSON, once.
TEST(FitOptionsTest, ToJsonHoldsEveryStruct) {
  const nlohmann::json j = FitOptions{}.ToJson();
  for (const char* key :
       {"seed", "trainer", "init", "expand", "expansion", "prior_cmd",
        "panorama_width", "iterations", "depth_weight", "warp_depth",
        "voxel_pixels", "resume", "deterministic", "checkpoint_every",
        "validate_every", "log_every", "time_budget"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["init"].at("num_bases"), InitOptions{}.num_bases);
  EXPECT_TRUE(j["trainer"].at("iterations").is_null());  // from the input
  EXPECT_EQ(j["expansion"].at("every"), ExpansionOptions{}.every);
}

// What changes the result is in the fingerprint; how the run goes is not.
TEST(FitOptionsTest, ResumeFingerprintLeavesTheConductOut) {
  const FitOptions a = ResolveFitOptions(FitOptions{}, {kDepthFromDataset});
  FitOptions conduct = a;
  conduct.resume = true;
  conduct.checkpoint_every = 7;
  conduct.validate_every = 3;
  conduct.log_every = 1;
  conduct.time_budget = 60;
  conduct.panorama_width = 64;
  EXPECT_EQ(ResumeFingerprint(a), ResumeFingerprint(conduct));
  FitOptions bases = a;
  bases.init.num_bases = 3;
  const std::optional<JsonDifference> d =
      FirstDifference(ResumeFingerprint(a), ResumeFingerprint(bases));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->path, "init.num_bases");
  FitOptions seed = a;
  seed.seed = 9;
  EXPECT_NE(ResumeFingerprint(a), ResumeFingerprint(seed));
  // Without the expansion its options do not matter.
  FitOptions off = a, off_other = a;
  off.expand = off_other.expand = false;
  off_other.expansion.every = 5;
  off_other.prior_cmd = "other {in} {out}";
  EXPECT_EQ(ResumeFingerprint(off), ResumeFingerprint(off_other));
}

TEST(FitOptionsTest, CheckNamesTheOption) {
  FitOptions o;
  o.deterministic = true;
  o.time_budget = 10;
  try {
    o.Check();
    FAIL() << "--deterministic with --time-budget was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), "--time-budget");
  }
  FitOptions bad;
  bad.checkpoint_every = 0;
  EXPECT_THROW(bad.Check(), Error);
  FitOptions init;
  init.init.sh_degree = 4;
  EXPECT_THROW(init.Check(), Error);
}

// The convergence stop is on for the default schedule (reading the
// validation frames when there are some) and off for a length given, unless
// asked for.
TEST(FitOptionsTest, TheConvergenceStopFollowsTheIterationsGiven) {
  EXPECT_EQ(ResolveFitOptions({}, {kDepthFromDataset, 48, 96}).converge_on,
            ConvergeOn::kValidation);
  EXPECT_EQ(ResolveFitOptions({}, {kDepthFromDataset, 48, 0}).converge_on,
            ConvergeOn::kTraining);
  FitOptions given;
  given.iterations = 500;
  EXPECT_EQ(ResolveFitOptions(given, {kDepthFromDataset, 48, 96}).converge_on,
            ConvergeOn::kOff);
  given.converge_on = ConvergeOn::kTraining;
  EXPECT_EQ(ResolveFitOptions(given, {kDepthFromDataset, 48, 96}).converge_on,
            ConvergeOn::kTraining);
  EXPECT_TRUE(FitOptions{}.ToJson().at("converge_on").is_null());
  EXPECT_EQ(given.ToJson().at("converge_on"), "train");
  // Where the fit ends is not what a step computes: a resume may change it.
  const FitOptions a = ResolveFitOptions(FitOptions{}, {kDepthFromDataset});
  FitOptions b = a;
  b.converge_on = ConvergeOn::kOff;
  b.convergence.window = 1000;
  EXPECT_EQ(ResumeFingerprint(a), ResumeFingerprint(b));
  FitOptions bad;
  bad.convergence.every = 0;
  EXPECT_THROW(bad.Check(), Error);
}

}  // namespace
}  // namespace pano4d
