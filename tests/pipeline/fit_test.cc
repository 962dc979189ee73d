// The fit controller in process, on the tiny synthetic scene: what its
// summary and fit.json record, why it stopped, and the one resume check.
#include "src/pipeline/fit.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/run_recorder.h"
#include "src/datasets/synth_generate.h"
#include "src/pipeline/depth.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;

class FitControllerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    synth::SynthOptions s;
    s.preset = "tiny";
    s.seed = 3;
    synth::GenerateSynthScene(s, dir_->path() / "tiny");
  }
  static void TearDownTestSuite() { delete dir_; }

  // A workspace listed from the tiny dataset (its depth given).
  static Workspace Listed(const std::string& name) {
    const Workspace ws(dir_->path() / name);
    DepthOptions d;
    d.dataset = dir_->path() / "tiny";
    RunDepth(ws, d);
    return ws;
  }

  static FitOptions Short(int iterations) {
    FitOptions o;
    o.iterations = iterations;
    o.expand = false;
    o.validate_every = o.checkpoint_every = iterations;
    return o;
  }

  static testing::TempDir* dir_;
};
testing::TempDir* FitControllerTest::dir_ = nullptr;

TEST_F(FitControllerTest, SummaryRecordsTheOptionsGivenAndUsed) {
  const Workspace ws = Listed("ws_summary");
  const FitSummary s = RunFit(ws, Short(20));
  EXPECT_EQ(s.termination, FitTermination::kIterationsDone);
  EXPECT_EQ(s.iterations, 20);
  EXPECT_FALSE(s.given.depth_weight);
  EXPECT_EQ(s.used.depth_weight, kGivenDepthWeight);
  EXPECT_EQ(s.used.trainer.depth_weight, kGivenDepthWeight);
  EXPECT_EQ(s.depth_source, kDepthFromDataset);
  EXPECT_FALSE(s.expanded);
  ASSERT_TRUE(s.evaluation);
  EXPECT_EQ(s.val_frames, 16u);
  EXPECT_GT(s.train_psnr, 10.0);
  const Json fit = ReadJson(ws.fit_json());
  EXPECT_EQ(fit, s.ToJson());
  EXPECT_EQ(fit.at("termination"), "iterations done");
  EXPECT_TRUE(fit.at("options_given").at("depth_weight").is_null());
  EXPECT_EQ(fit.at("options_used").at("depth_weight"), kGivenDepthWeight);
  EXPECT_EQ(fit.at("options_used").at("init"), InitOptions{}.ToJson());
  EXPECT_TRUE(fit.at("metrics").at("mpsnr").is_number());
  EXPECT_NE(s.FullReport().find("none (--no-expansion)"), std::string::npos);
  EXPECT_NE(s.BriefReport().find("20 iterations (iterations done)"),
            std::string::npos)
      << s.BriefReport();
}

// Stop() before Run() stops after the first iteration, checkpointed; the
// run resumes to the end from there.
TEST_F(FitControllerTest, StopCheckpointsAndTheRunResumes) {
  const Workspace ws = Listed("ws_stop");
  FitController stopped(ws, Short(12), LoadFitInputs(ws));
  stopped.Stop();
  const FitSummary a = stopped.Run();
  EXPECT_EQ(a.termination, FitTermination::kStopped);
  EXPECT_EQ(a.iterations, 1);
  EXPECT_TRUE(fs::exists(ws.checkpoint()));
  EXPECT_EQ(ReadJson(ws.fit_json()).at("termination"), "stopped");
  FitOptions resume = Short(12);
  resume.resume = true;
  const FitSummary b = RunFit(ws, resume);
  EXPECT_EQ(b.termination, FitTermination::kIterationsDone);
  EXPECT_EQ(b.resumed_at, 1);
  EXPECT_EQ(b.iterations, 12);

  FitOptions budget = Short(12);
  budget.time_budget = 1e-9;
  const FitSummary c = RunFit(Listed("ws_budget"), budget);
  EXPECT_EQ(c.termination, FitTermination::kTimeBudget);
  EXPECT_EQ(c.iterations, 1);
}

// One check, of every option that changes the result, naming the first
// that differs; how the run goes may change.
TEST_F(FitControllerTest, ResumingWithAChangedOptionIsRefusedByName) {
  const Workspace ws = Listed("ws_resume");
  RunFit(ws, Short(10));
  const FitOptions used = ResolveFitOptions(Short(10), {kDepthFromDataset});
  const FitInputs inputs = LoadFitInputs(ws);
  EXPECT_FALSE(CheckpointMismatch(ws, used, inputs.train));
  // Other frames (one pixel changed): another scene.
  std::vector<TrainingView> other_frames = inputs.train;
  other_frames[0].rgb[0] += 0.5f;
  EXPECT_EQ(CheckpointMismatch(ws, used, other_frames).value_or(""),
            "the training frames changed");
  FitOptions other = Short(10);
  other.resume = true;
  other.init.num_bases = 3;
  try {
    RunFit(ws, other);
    FAIL() << "a checkpoint of 20 motion bases resumed with 3";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "option init.num_bases") << e.what();
    EXPECT_EQ(e.value(), "20") << e.what();
  }
  const std::optional<std::string> why = CheckpointMismatch(
      ws, ResolveFitOptions(other, {kDepthFromDataset}), inputs.train);
  ASSERT_TRUE(why);
  EXPECT_NE(why->find("init.num_bases"), std::string::npos) << *why;
  FitOptions seed = Short(10);
  seed.resume = true;
  seed.seed = 5;
  EXPECT_THROW(RunFit(ws, seed), Error);
  FitOptions conduct = Short(10);
  conduct.resume = true;
  conduct.log_every = 1;
  conduct.checkpoint_every = 3;
  EXPECT_EQ(RunFit(ws, conduct).resumed_at, 10);
}

// The fit's reuse goes through the stages' one mechanism (src/core/
// stamp.h): a stamp written once every iteration ran, none for a fit that
// stopped early, and the reason it runs again when an option or the frames
// changed.
TEST_F(FitControllerTest, ItsStampSaysWhyItRunsAgain) {
  const Workspace ws = Listed("ws_stamp");
  const StageStamp stamp(ws, "fit");
  FitController stopped(ws, Short(6), LoadFitInputs(ws));
  stopped.Stop();
  stopped.Run();
  EXPECT_FALSE(fs::exists(ws.stamps() / "fit.json"));
  RunFit(ws, Short(6));
  const FitOptions used = ResolveFitOptions(Short(6), {kDepthFromDataset});
  const FitInputs inputs = LoadFitInputs(ws);
  EXPECT_EQ(stamp.StaleReason(FitStageRecord(ws, used, inputs.train)),
            std::nullopt);
  EXPECT_GT(stamp.Seconds(), 0.0);
  FitOptions other = Short(6);
  other.init.num_bases = 3;
  EXPECT_EQ(
      stamp
          .StaleReason(FitStageRecord(
              ws, ResolveFitOptions(other, {kDepthFromDataset}), inputs.train))
          .value_or(""),
      "option init.num_bases was 20, now 3");
  EXPECT_EQ(stamp
                .StaleReason(FitStageRecord(
                    ws, ResolveFitOptions(Short(9), {kDepthFromDataset}),
                    inputs.train))
                .value_or(""),
            "option iterations was 6, now 9");
  std::vector<TrainingView> other_frames = inputs.train;
  other_frames[0].rgb[0] += 0.5f;
  EXPECT_EQ(stamp.StaleReason(FitStageRecord(ws, used, other_frames)),
            "the training frames changed");
  fs::remove(ws.checkpoint());
  EXPECT_EQ(stamp.StaleReason(FitStageRecord(ws, used, inputs.train)),
            "its output pano4d/checkpoints/fit.ckpt is gone");
}

// The convergence stop ends a fit as `converged` with its reason, on the
// validation PSNR when there are validation frames; a fit resumed from that
// checkpoint ends at once, as the uninterrupted run did; a length given
// without --converge-on runs to its end.
TEST_F(FitControllerTest, AConvergedFitSaysWhyAndIterationsOverride) {
  const Workspace ws = Listed("ws_converge");
  FitOptions o = Short(60);
  o.converge_on = ConvergeOn::kAuto;
  o.trainer.strategy.densify_until = 10;
  o.convergence.every = 10;
  o.convergence.window = 20;
  o.convergence.min_gain = 100;  // no window gains that much
  const FitSummary a = RunFit(ws, o);
  EXPECT_EQ(a.termination, FitTermination::kConverged);
  EXPECT_EQ(a.iterations, 40);  // samples after 10: 20, 30, 40 against 20
  EXPECT_EQ(a.used.converge_on, ConvergeOn::kValidation);
  const Json fit = ReadJson(ws.fit_json());
  EXPECT_EQ(fit.at("termination"), "converged");
  EXPECT_EQ(fit.at("convergence").at("signal"), "val");
  EXPECT_EQ(fit.at("convergence").at("gate"), 10);
  EXPECT_EQ(fit.at("convergence").at("samples").size(), 3u);
  const std::string reason = fit.at("convergence").at("reason");
  EXPECT_NE(reason.find("over the last 20 iterations (less than 100"),
            std::string::npos)
      << reason;
  EXPECT_NE(a.FullReport().find("(converged on val: PSNR"), std::string::npos)
      << a.FullReport();
  // The run log has the sample's rows with validation; the fit is complete
  // for `run` (its stamp).
  const RunLog log = ReadRunLog(ws.fit_csv());
  ASSERT_FALSE(log.iterations.empty());
  EXPECT_EQ(log.iterations.back(), 40);
  EXPECT_TRUE(fs::exists(ws.stamps() / "fit.json"));
  EXPECT_TRUE(fs::exists(ws.fit_plot()));

  FitOptions resume = o;
  resume.resume = true;
  const FitSummary b = RunFit(ws, resume);
  EXPECT_EQ(b.termination, FitTermination::kConverged);
  EXPECT_EQ(b.resumed_at, 40);
  EXPECT_EQ(b.iterations, 40);

  // The validation signal where there are no validation frames: refused.
  FitInputs no_val = LoadFitInputs(ws);
  no_val.val.clear();
  FitOptions val = o;
  val.converge_on = ConvergeOn::kValidation;
  EXPECT_THROW(
      FitController(Listed("ws_converge_noval"), val, std::move(no_val)).Run(),
      Error);

  FitOptions given = o;
  given.converge_on.reset();  // --iterations 60 alone
  const FitSummary c = RunFit(Listed("ws_converge_off"), given);
  EXPECT_EQ(c.termination, FitTermination::kIterationsDone);
  EXPECT_EQ(c.iterations, 60);
  EXPECT_EQ(c.used.converge_on, ConvergeOn::kOff);
  EXPECT_TRUE(ReadJson(Workspace(dir_->path() / "ws_converge_off").fit_json())
                  .at("convergence")
                  .is_null());
}

}  // namespace
}  // namespace pano4d
