// The stage planner of `pano4d run`: every rule that leaves a stage out, and
// the reason it gives.
#include "src/pipeline/planner.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/frames.h"

namespace pano4d {
namespace {

PlanFacts Video() {
  PlanFacts f;
  f.input = InputKind::kVideo;
  f.input_path = "clip.mp4";
  return f;
}

PlanFacts SynthDataset() {
  PlanFacts f;
  f.input = InputKind::kDataset;
  f.input_path = "small";
  f.poses_given = true;
  f.depth_given = true;
  f.dynamic_fraction = 0.1;
  f.target_views = 96;
  f.unseen_fraction = 0.35;
  f.ground_truth = true;
  f.eval_requested = true;
  return f;
}

TEST(PlannerTest, AVideoRunsEveryStageButEvaluation) {
  const Plan plan = MakePlan(Video());
  ASSERT_EQ(plan.stages.size(), 6u);
  const char* order[] = {"sfm", "depth", "motion", "fit", "expansion", "eval"};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(plan.stages[i].stage, order[i]);
  EXPECT_TRUE(plan.Runs("sfm"));
  EXPECT_TRUE(plan.Runs("depth"));
  EXPECT_TRUE(plan.Get("motion").pending);
  EXPECT_NE(plan.Get("motion").why.find("after depth"), std::string::npos);
  EXPECT_TRUE(plan.Runs("fit"));
  // No target views: the expansion's own trajectories are the targets.
  EXPECT_TRUE(plan.Runs("expansion"));
  EXPECT_FALSE(plan.Runs("eval"));
  EXPECT_NE(plan.Get("eval").why.find("no ground truth"), std::string::npos);
}

TEST(PlannerTest, TheShareOfFramesPosedIsAFactOfThePlan) {
  PlanFacts f = Video();
  f.min_posed = 0.9;
  const Plan before = MakePlan(f);
  EXPECT_NE(before.Get("sfm").why.find("fewer than 90.00% of them "
                                       "(--min-posed)"),
            std::string::npos)
      << before.Get("sfm").why;
  EXPECT_TRUE(before.ToJson()["facts"]["sfm_posed_fraction"].is_null());
  f.sfm_frames = 145;
  f.sfm_posed = 12;
  const Plan after = MakePlan(f);
  EXPECT_NE(after.Get("sfm").why.find("posed 12 of 145 (8.28%)"),
            std::string::npos)
      << after.Get("sfm").why;
  const nlohmann::json facts = after.ToJson()["facts"];
  EXPECT_EQ(facts["sfm_frames"], 145);
  EXPECT_EQ(facts["sfm_posed"], 12);
  EXPECT_NEAR(facts["sfm_posed_fraction"].get<double>(), 12.0 / 145, 1e-12);
  EXPECT_DOUBLE_EQ(facts["min_posed"].get<double>(), 0.9);
}

TEST(PlannerTest, GivenPosesAndDepthLeaveSfmAndDepthOut) {
  PlanFacts colmap = Video();
  colmap.input = InputKind::kColmap;
  colmap.poses_given = true;
  Plan plan = MakePlan(colmap);
  EXPECT_FALSE(plan.Runs("sfm"));
  EXPECT_NE(plan.Get("sfm").why.find("poses given"), std::string::npos);
  EXPECT_TRUE(plan.Runs("depth"));

  plan = MakePlan(SynthDataset());
  EXPECT_FALSE(plan.Runs("sfm"));
  EXPECT_FALSE(plan.Runs("depth"));
  EXPECT_NE(plan.Get("depth").why.find("depth given"), std::string::npos);
  EXPECT_TRUE(plan.Runs("eval"));

  // A dataset without depth: COLMAP triangulates points with its cameras,
  // and stereo on those cameras gives the depth; the plan names the source.
  PlanFacts no_depth = SynthDataset();
  no_depth.depth_given = false;
  plan = MakePlan(no_depth);
  EXPECT_EQ(plan.facts.depth_source, kDepthFromStereo);
  EXPECT_TRUE(plan.Runs("sfm"));
  EXPECT_NE(plan.Get("sfm").why.find("point_triangulator"), std::string::npos);
  EXPECT_NE(plan.Get("sfm").why.find("dataset's cameras"), std::string::npos);
  EXPECT_TRUE(plan.Runs("depth"));
  EXPECT_NE(plan.Get("depth").why.find("stereo"), std::string::npos);
  EXPECT_NE(plan.Get("depth").why.find("dataset's cameras"), std::string::npos);

  // --depth-dir is the user's word: preferred to the dataset's own depth,
  // and aligned to triangulated points.
  PlanFacts external = SynthDataset();
  external.depth_dir = "other-tool/depth";
  plan = MakePlan(external);
  EXPECT_EQ(plan.facts.depth_source, kDepthFromExternal);
  EXPECT_TRUE(plan.Runs("sfm"));
  EXPECT_NE(plan.Get("sfm").why.find("--depth-dir"), std::string::npos);
  EXPECT_TRUE(plan.Runs("depth"));
  EXPECT_NE(plan.Get("depth").why.find("other-tool/depth"), std::string::npos);
  EXPECT_EQ(plan.ToJson()["facts"]["depth_source"], kDepthFromExternal);
}

TEST(PlannerTest, TargetsAtTrainingCamerasNeedNoExpansion) {
  // The Nvidia protocol: view 0 tests, and view 0 trains at time 0.
  PlanFacts f = SynthDataset();
  f.unseen_fraction.reset();
  EXPECT_TRUE(MakePlan(f).Runs("expansion"));  // coverage unknown
  f.targets_are_training_cameras = true;
  const Plan plan = MakePlan(f);
  EXPECT_FALSE(plan.Runs("expansion"));
  EXPECT_NE(plan.Get("expansion").why.find("training cameras"),
            std::string::npos);
  // Covisibility masks, where given, are the better fact.
  f.unseen_fraction = 0.35;
  EXPECT_TRUE(MakePlan(f).Runs("expansion"));
}

TEST(PlannerTest, NoDynamicContentMeansNoMotion) {
  PlanFacts f = SynthDataset();
  f.dynamic_fraction = 0.0;
  Plan plan = MakePlan(f);
  EXPECT_FALSE(plan.Runs("motion"));
  EXPECT_FALSE(plan.Get("motion").pending);
  EXPECT_NE(plan.Get("motion").why.find("no dynamic content"),
            std::string::npos);
  f.dynamic_fraction = kMinDynamicFraction * 0.5;
  EXPECT_FALSE(MakePlan(f).Runs("motion"));
  f.dynamic_fraction = kMinDynamicFraction * 2;
  EXPECT_TRUE(MakePlan(f).Runs("motion"));
  f.no_motion = true;
  plan = MakePlan(f);
  EXPECT_FALSE(plan.Runs("motion"));
  EXPECT_NE(plan.Get("motion").why.find("--no-motion"), std::string::npos);
}

TEST(PlannerTest, NoTargetOutsideTheCoverageMeansNoExpansion) {
  PlanFacts f = SynthDataset();
  f.unseen_fraction = kMinUnseenFraction * 0.5;
  Plan plan = MakePlan(f);
  EXPECT_FALSE(plan.Runs("expansion"));
  EXPECT_NE(plan.Get("expansion").why.find("outside the training coverage"),
            std::string::npos);
  f.unseen_fraction = 0.2;
  plan = MakePlan(f);
  EXPECT_TRUE(plan.Runs("expansion"));
  EXPECT_NE(plan.Get("expansion").why.find("20.00%"), std::string::npos);
  // Target views of unknown coverage: expand.
  f.unseen_fraction.reset();
  EXPECT_TRUE(MakePlan(f).Runs("expansion"));
  f.no_expansion = true;
  plan = MakePlan(f);
  EXPECT_FALSE(plan.Runs("expansion"));
  EXPECT_NE(plan.Get("expansion").why.find("--no-expansion"),
            std::string::npos);
}

TEST(PlannerTest, EvaluationNeedsGroundTruthAndTheAsking) {
  PlanFacts f = SynthDataset();
  f.eval_requested = false;
  Plan plan = MakePlan(f);
  EXPECT_FALSE(plan.Runs("eval"));
  EXPECT_NE(plan.Get("eval").why.find("--eval"), std::string::npos);
  f.eval_requested = true;
  f.ground_truth = false;
  EXPECT_FALSE(MakePlan(f).Runs("eval"));
}

TEST(PlannerTest, JsonAndTableSayEveryStageAndWhy) {
  const Plan plan = MakePlan(SynthDataset());
  const nlohmann::json j = plan.ToJson();
  EXPECT_EQ(j["input"]["kind"], "dataset");
  EXPECT_DOUBLE_EQ(j["facts"]["unseen_fraction"].get<double>(), 0.35);
  ASSERT_EQ(j["stages"].size(), 6u);
  for (const auto& s : j["stages"]) {
    EXPECT_TRUE(s.contains("run"));
    EXPECT_FALSE(s["why"].get<std::string>().empty());
  }
  const std::string table = plan.Table();
  EXPECT_NE(table.find("sfm        left out"), std::string::npos) << table;
  EXPECT_NE(table.find("fit        run"), std::string::npos) << table;
  EXPECT_THROW(plan.Get("tracks"), Error);
  // Unknown facts are null, not made up.
  EXPECT_TRUE(
      MakePlan(Video()).ToJson()["facts"]["dynamic_fraction"].is_null());
}

}  // namespace
}  // namespace pano4d
