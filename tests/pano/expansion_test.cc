#include "src/pano/expansion.h"

#include <algorithm>
#include <filesystem>
#include <numeric>
#include <optional>
#include <set>

#include <opencv2/imgcodecs.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/npy.h"
#include "src/gs/trainer.h"
#include "src/render/bench_scene.h"
#include "src/render/rasterizer.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

constexpr int kWidth = 48, kHeight = 36;

RasterCamera CameraAt(float x) {
  RasterCamera camera = BenchCamera(kWidth, kHeight);
  camera.translation = Eigen::Vector3f(-x, 0, 0);
  return camera;
}

// A static scene seen by four cameras along x at times 0..3, and a trainer
// holding a copy of it (as if fitted). The Gaussians fill depths 2 to 4, or
// with `surface` lie within 1% of depth 3, as a fit leaves them on a surface.
// With `moving`, the views' dynamic masks mark a rectangle (kMovingRect).
// The views' depth maps are the rendered depth times `given_depth_scale`
// (0: no depth anywhere).
const cv::Rect kMovingRect(18, 12, 12, 10);
std::unique_ptr<Trainer> MakeTrainer(bool surface = false, bool moving = false,
                                     float given_depth_scale = 1.0f) {
  GaussianScene scene;
  scene.statics = RandomViewFillingScene(800, CameraAt(0), 3.0f, 5);
  if (surface) {
    std::vector<float>& means = scene.statics.means;
    for (std::size_t i = 0; i < means.size(); i += 3) {
      const float z = means[i + 2], to = 3.0f + 0.015f * (z - 3.0f);
      for (int k = 0; k < 3; ++k) means[i + k] *= to / z;  // same pixel
    }
  }
  scene.dynamics.sh_degree = scene.statics.sh_degree;
  scene.num_times = 4;
  std::vector<TrainingView> views;
  Rasterizer rasterizer;
  RenderOutput out;
  for (int t = 0; t < 4; ++t) {
    TrainingView v;
    v.name = "f" + std::to_string(t);
    v.time = t;
    v.camera = CameraAt(0.1f * t);
    rasterizer.Render(scene.statics, v.camera, {}, &out);
    v.rgb = out.rgb;
    v.depth = out.depth;
    for (float& d : v.depth) d *= given_depth_scale;
    if (moving) {
      v.dynamic.assign(kWidth * kHeight, 0);
      for (int y = kMovingRect.y; y < kMovingRect.br().y; ++y)
        for (int x = kMovingRect.x; x < kMovingRect.br().x; ++x)
          v.dynamic[y * kWidth + x] = kMaskOn;
    }
    views.push_back(std::move(v));
  }
  TrainerOptions o;
  o.iterations = 100;
  o.strategy.densify_from = 1000000;
  o.strategy.opacity_reset_every = 1000000;
  return std::make_unique<Trainer>(std::move(scene), std::move(views), o,
                                   /*seed=*/0);
}

ExpansionOptions SmallOptions() {
  ExpansionOptions o;
  o.geometry.directions = 2;
  o.geometry.steps = 2;
  o.geometry.alpha_degrees = 12;
  o.time_stride = 1;
  o.every = 10;
  return o;
}

TEST(ExpansionScheduleTest, SpreadsTheStepsOverTheExpansions) {
  ExpansionOptions o;  // E = 6, every 2000
  std::vector<int> all;
  for (std::int64_t it = 0; it <= 10000; ++it) {
    const std::vector<int> due = StepsDueAt(o, it, 10000);
    if (it == 2000) {
      EXPECT_EQ(due, (std::vector<int>{1, 2}));
    } else if (it == 4000) {
      EXPECT_EQ(due, (std::vector<int>{3}));
    } else if (it == 8000) {
      EXPECT_EQ(due, (std::vector<int>{6}));
    }
    if (it % 2000 != 0 || it == 0 || it == 10000) {
      EXPECT_TRUE(due.empty()) << it;
    }
    all.insert(all.end(), due.begin(), due.end());
  }
  EXPECT_EQ(all, (std::vector<int>{1, 2, 3, 4, 5, 6}));
  // One step at the full angle, at the first expansion.
  o.one_step = true;
  EXPECT_EQ(StepsDueAt(o, 2000, 10000), std::vector<int>{6});
  EXPECT_TRUE(StepsDueAt(o, 4000, 10000).empty());
  // A run too short for an expansion has none.
  o.one_step = false;
  EXPECT_TRUE(StepsDueAt(o, 2000, 2000).empty());
  // More expansions than steps: one step each until they run out.
  o.every = 100;
  int steps = 0;
  for (std::int64_t it = 0; it < 10000; ++it)
    steps += static_cast<int>(StepsDueAt(o, it, 10000).size());
  EXPECT_EQ(steps, 6);
}

// A fit resumed at iteration i continues after the last step before i: a
// step due at i itself has not run (the checkpoint comes after the step).
TEST(ExpansionScheduleTest, ResumeContinuesAfterTheLastStepBefore) {
  ExpansionOptions o;  // steps 1-2 at 2000, 3 at 4000, 4-5 at 6000, 6 at 8000
  EXPECT_EQ(LastStepBefore(o, 0, 10000), 0);
  EXPECT_EQ(LastStepBefore(o, 2000, 10000), 0);
  EXPECT_EQ(LastStepBefore(o, 2001, 10000), 2);
  EXPECT_EQ(LastStepBefore(o, 4500, 10000), 3);
  EXPECT_EQ(LastStepBefore(o, 10000, 10000), 6);
  o.one_step = true;
  EXPECT_EQ(LastStepBefore(o, 9000, 10000), 6);
}

TEST(ExpansionTest, StepWarpsFillsAddsGaussiansAndQueuesRefinement) {
  testing::TempDir dir;
  auto trainer = MakeTrainer();
  GeometryPrior prior;
  Expansion expansion(SmallOptions(), /*seed=*/0, dir.path(), &prior);
  const std::size_t before = trainer->scene().statics.size();
  const ExpansionStepReport r1 = expansion.RunStep(trainer.get(), 1);
  EXPECT_EQ(r1.views, 2 * 4);
  EXPECT_DOUBLE_EQ(r1.angle_degrees, 12.0);
  EXPECT_GT(r1.hole_fraction, 0.0);  // the orbit looks past the video's edge
  EXPECT_LT(r1.hole_fraction, 0.9);
  EXPECT_EQ(r1.prefilled_fraction, 0.0);  // nothing to chain from
  // Recorded; its value means little here: the scene is a cloud of small
  // Gaussians at random depths, whose many narrow disocclusions the measure
  // counts as cracks.
  EXPECT_GE(r1.crack_fraction, 0.0);
  EXPECT_LE(r1.crack_fraction, 1.0);
  EXPECT_EQ(r1.ToJson().at("crack_fraction").get<double>(), r1.crack_fraction);
  EXPECT_GT(r1.new_gaussians, 0);
  EXPECT_EQ(trainer->scene().statics.size(),
            before + static_cast<std::size_t>(r1.new_gaussians - r1.carved));
  EXPECT_EQ(r1.prior, "geometry");
  for (const char* kind : {"warped", "mask", "refined"})
    EXPECT_TRUE(std::filesystem::exists(dir.path() / "step_01" / "dir_1" /
                                        kind / "f3.png"))
        << kind;
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "step_01" / "cameras.json"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "frame.json"));
  EXPECT_EQ(expansion.refinement_views(), 8u);

  // Refinement views: chosen by the iteration alone, masks of the view.
  const ExtraView* a = expansion.ViewFor(7);
  ASSERT_NE(a, nullptr);
  const std::vector<float> target = a->target;
  EXPECT_EQ(a->mask.size(), static_cast<std::size_t>(kWidth * kHeight));
  EXPECT_EQ(target.size(), a->mask.size() * 3);
  EXPECT_DOUBLE_EQ(a->weight, 0.1);
  EXPECT_DOUBLE_EQ(a->outside_weight, ExpansionOptions().refine_outside_weight);
  expansion.ViewFor(8);
  EXPECT_EQ(expansion.ViewFor(7)->target, target);
  // A step trains on it: the hook is used and the loss counts it.
  trainer->extra_view = [&](std::int64_t it) { return expansion.ViewFor(it); };
  const StepReport step = trainer->Step();
  EXPECT_GT(step.extra, 0.0);
  EXPECT_TRUE(std::isfinite(step.loss));

  // Step 2 chains step 1's refined frames into its holes.
  const ExpansionStepReport r2 = expansion.RunStep(trainer.get(), 2);
  EXPECT_GT(r2.hole_fraction, 0.0);
  EXPECT_GT(r2.prefilled_fraction, 0.0);
  EXPECT_EQ(expansion.refinement_views(), 16u);
  EXPECT_EQ(expansion.cameras().size(), 16u);
}

// The expansion needs only SceneEditor: over a bare scene (no trainer, no
// optimiser) a step makes the same views and Gaussians as over a Trainer
// holding that scene.
class BareScene : public SceneEditor {
 public:
  BareScene(GaussianScene scene, std::vector<TrainingView> views)
      : scene_(std::move(scene)), views_(std::move(views)) {}
  void Render(const RasterCamera& camera, int time,
              RenderOutput* out) override {
    ++renders;
    scene_.ComposeAt(time, &composed_);
    rasterizer_.Render(composed_, camera, {}, out);
  }
  const std::vector<TrainingView>& views() const override { return views_; }
  const GaussianScene& scene() const override { return scene_; }
  std::int64_t AddStaticGaussians(const GaussianModel& extra) override {
    std::vector<std::uint32_t> rows(extra.size());
    std::iota(rows.begin(), rows.end(), 0u);
    AppendGaussianRows(extra, rows, &scene_.statics);
    return static_cast<std::int64_t>(extra.size());
  }
  std::int64_t RemoveStaticGaussians(
      const std::vector<std::uint8_t>& keep) override {
    const std::size_t before = scene_.statics.size();
    KeepGaussianRows(keep, &scene_.statics);
    return static_cast<std::int64_t>(before - scene_.statics.size());
  }
  int renders = 0;

 private:
  GaussianScene scene_;
  std::vector<TrainingView> views_;
  Rasterizer rasterizer_;
  GaussianModel composed_;
};

// The layout's shell goes where no training frame saw: a training view
// renders almost as before where it saw a surface, while a camera
// turned round to the wall behind the frames, which none saw, sees a
// surface instead of the background.
TEST(ExpansionTest, TheLayoutShellCoversWhatNoFrameSawAndNothingSeen) {
  testing::TempDir dir;
  auto trainer = MakeTrainer(/*surface=*/true);
  GeometryPrior prior;
  Expansion expansion(SmallOptions(), /*seed=*/0, dir.path(), &prior);
  RasterCamera back = CameraAt(0.15f);  // at (0.15, 0, 0), looking along -z
  back.rotation = Eigen::Vector3f(-1, 1, -1).asDiagonal();
  back.translation = -(back.rotation * Eigen::Vector3f(0.15f, 0, 0));
  const auto render = [&](const RasterCamera& c) {
    RenderOutput out;
    trainer->Render(c, 0, &out);
    return out;
  };
  const RenderOutput front_before = render(trainer->views()[1].camera);
  const RenderOutput back_before = render(back);
  const std::size_t before = trainer->scene().statics.size();

  const Expansion::Shell shell = expansion.AddLayoutShell(trainer.get());
  EXPECT_GE(shell.planes, 1);  // the surface the frames saw
  EXPECT_GT(shell.gaussians, 0);
  EXPECT_EQ(trainer->scene().statics.size(),
            before + static_cast<std::size_t>(shell.gaussians));

  // The frames saw one wall, a fitted plane: the shell continues it past
  // their edges, where the tails of its Gaussians just outside a frame
  // reach into that frame's border (the plane's colour on the plane,
  // which the frame's loss then corrects); inside, the view renders as
  // before.
  const TrainingView& front = trainer->views()[1];
  const RenderOutput front_after = render(front.camera);
  constexpr int kBorder = 6;  // pixels: 3 sigma of a shell Gaussian here
  double seen_change = 0;
  std::size_t seen = 0;
  for (int y = kBorder; y < kHeight - kBorder; ++y) {
    for (int x = kBorder; x < kWidth - kBorder; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * kWidth + x;
      if (!(front.depth[p] > 0)) continue;
      ++seen;
      for (int k = 0; k < 3; ++k)
        seen_change +=
            std::abs(front_after.rgb[3 * p + k] - front_before.rgb[3 * p + k]);
    }
  }
  ASSERT_GT(seen, front.depth.size() / 4);
  EXPECT_LT(seen_change / (3 * seen), 3e-3);
  const RenderOutput back_after = render(back);
  const auto mean_alpha = [](const RenderOutput& out) {
    return std::accumulate(out.alpha.begin(), out.alpha.end(), 0.0) /
           static_cast<double>(out.alpha.size());
  };
  EXPECT_LT(mean_alpha(back_before), 0.05);
  EXPECT_GT(mean_alpha(back_after), 0.8);
}

TEST(ExpansionTest, RunsOnAnySceneEditorAsOnATrainer) {
  testing::TempDir dir;
  auto trainer = MakeTrainer();
  BareScene bare(trainer->scene(), trainer->views());
  GeometryPrior prior;
  Expansion on_trainer(SmallOptions(), /*seed=*/0, dir / "trainer", &prior);
  Expansion on_bare(SmallOptions(), /*seed=*/0, dir / "bare", &prior);
  const ExpansionStepReport a = on_trainer.RunStep(trainer.get(), 1);
  const ExpansionStepReport b = on_bare.RunStep(&bare, 1);
  EXPECT_GT(bare.renders, 0);
  EXPECT_GT(b.new_gaussians, 0);
  EXPECT_EQ(a.new_gaussians, b.new_gaussians);
  EXPECT_EQ(a.carved, b.carved);
  EXPECT_DOUBLE_EQ(a.hole_fraction, b.hole_fraction);
  EXPECT_EQ(bare.scene().statics.means, trainer->scene().statics.means);
  EXPECT_EQ(on_bare.ViewFor(3)->target, on_trainer.ViewFor(3)->target);
}

TEST(ExpansionTest, ReloadServesTheSameViewsAsTheRunThatWroteThem) {
  testing::TempDir dir;
  auto trainer = MakeTrainer();
  GeometryPrior prior;
  Expansion first(SmallOptions(), /*seed=*/0, dir.path(), &prior);
  first.RunStep(trainer.get(), 1);
  first.RunStep(trainer.get(), 2);

  Expansion resumed(SmallOptions(), /*seed=*/0, dir.path(), &prior);
  resumed.Reload(*trainer, 2);
  ASSERT_EQ(resumed.refinement_views(), first.refinement_views());
  for (std::int64_t it : {1, 5, 17, 40}) {
    const ExtraView* a = first.ViewFor(it);
    const std::vector<float> target = a->target;
    const std::vector<std::uint8_t> mask = a->mask;
    const ExtraView* b = resumed.ViewFor(it);
    EXPECT_EQ(b->target, target) << it;
    EXPECT_EQ(b->mask, mask) << it;
    EXPECT_EQ(b->time, a->time);
  }
  // Missing products are an error that says what to do.
  std::filesystem::remove_all(dir.path() / "step_01");
  Expansion broken(SmallOptions(), /*seed=*/0, dir.path(), &prior);
  EXPECT_THROW(broken.Reload(*trainer, 2), Error);
}

// L_refine supervises M_e only; a static floater in front of content the
// warp brought into an expanded view is removed by the carving, also where
// no training frame sees it.
TEST(ExpansionTest, CarvingRemovesAFloaterOnlyAWarpSeesThrough) {
  testing::TempDir dir;
  auto trainer = MakeTrainer(/*surface=*/true);
  GeometryPrior prior;
  Expansion expansion(SmallOptions(), /*seed=*/0, dir.path(), &prior);
  EXPECT_EQ(expansion.Carve(trainer.get()), 0);  // nothing before a step
  const std::size_t before = trainer->scene().statics.size();
  const ExpansionStepReport r = expansion.RunStep(trainer.get(), 1);
  // The fitted scene stands: its Gaussians lie on what the frames saw.
  EXPECT_LT(r.carved, static_cast<std::int64_t>(before / 50)) << r.carved;
  EXPECT_EQ(expansion.Carve(trainer.get()), 0);  // nothing changed since

  // A point half way to a warped surface of an expanded view, out of every
  // training frame's sight.
  std::vector<SeenDepth> frames;
  for (const TrainingView& v : trainer->views())
    frames.push_back(
        MakeSeenDepth(v.camera, cv::Mat(kHeight, kWidth, CV_32FC1,
                                        const_cast<float*>(v.depth.data()))));
  std::optional<Eigen::Vector3f> floater;
  for (const ExpandedView& v : expansion.cameras()) {
    const std::filesystem::path d =
        dir.path() / "step_01" / ("dir_" + std::to_string(v.m));
    const cv::Mat mask = cv::imread((d / "mask" / (v.name + ".png")).string(),
                                    cv::IMREAD_GRAYSCALE);
    const std::vector<float> depth =
        ReadNpy(d / "depth" / (v.name + ".npy")).ToFloats();
    const RasterCamera& c = v.camera;
    for (int y = 1; y + 1 < kHeight && !floater; ++y) {
      for (int x = 1; x + 1 < kWidth && !floater; ++x) {
        // The warp's surface all around (the test spares its edges).
        if (cv::countNonZero(mask(cv::Rect(x - 1, y - 1, 3, 3))) > 0) continue;
        const float z = 0.5f * depth[y * kWidth + x];
        const Eigen::Vector3f p =
            c.rotation.transpose() *
            (Eigen::Vector3f((x + 0.5f - c.cx) / c.fx * z,
                             (y + 0.5f - c.cy) / c.fy * z, z) -
             c.translation);
        if (Look(frames, p) == Sight::kUnseen) floater = p;
      }
    }
    if (floater) break;
  }
  ASSERT_TRUE(floater) << "no point that only a warp sees through";
  GaussianModel one = RandomViewFillingScene(1, CameraAt(0), 3.0f, 1);
  for (int k = 0; k < 3; ++k) one.means[k] = (*floater)[k];
  ASSERT_EQ(trainer->AddStaticGaussians(one), 1);
  EXPECT_EQ(expansion.Carve(trainer.get()), 1);
  EXPECT_EQ(expansion.carved(), r.carved + 1);
  const std::vector<float>& means = trainer->scene().statics.means;
  for (std::size_t i = 0; i < means.size(); i += 3)
    ASSERT_FALSE(means[i] == (*floater)[0] && means[i + 1] == (*floater)[1] &&
                 means[i + 2] == (*floater)[2]);
}

TEST(ExpansionTest, WithoutGaussianRefinementNothingIsDistilled) {
  testing::TempDir dir;
  auto trainer = MakeTrainer();
  GeometryPrior prior;
  ExpansionOptions o = SmallOptions();
  o.gaussian_refinement = false;
  Expansion expansion(o, /*seed=*/0, dir.path(), &prior);
  const std::size_t before = trainer->scene().statics.size();
  const ExpansionStepReport r = expansion.RunStep(trainer.get(), 1);
  EXPECT_EQ(r.new_gaussians, 0);
  EXPECT_EQ(trainer->scene().statics.size(), before);
  EXPECT_EQ(expansion.ViewFor(3), nullptr);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "step_01" / "dir_0" /
                                      "refined" / "f0.png"));
}

// Fills every masked pixel with one colour (which the test may change).
class ConstantPrior : public Prior {
 public:
  cv::Vec3f colour{1, 0, 1};
  std::string name() const override { return "constant"; }
  PriorResult Fill(const PriorClip& clip) override {
    PriorResult r;
    r.prior = name();
    for (const cv::Mat& f : clip.frames) {
      cv::Mat filled = f.clone();
      filled.setTo(cv::Scalar(colour[0], colour[1], colour[2]),
                   clip.masks[r.frames.size()]);
      r.frames.push_back(filled);
    }
    return r;
  }
};

double MeanAbsDifference(const cv::Mat& a, const cv::Mat& b) {
  const cv::Scalar d = cv::mean(cv::abs(a - b));
  return (d[0] + d[1] + d[2]) / 3;
}

// Keeps every clip it is asked to fill.
class RecordingPrior : public ConstantPrior {
 public:
  std::vector<PriorClip> clips;
  PriorResult Fill(const PriorClip& clip) override {
    clips.push_back(clip);
    return ConstantPrior::Fill(clip);
  }
};

// The prior learns which warped pixels show moving content (the sources'
// dynamic masks warped like the frames), so that it can keep them to their
// own time.
TEST(ExpansionTest, StepTellsThePriorWhichPixelsMove) {
  for (bool moving : {false, true}) {
    SCOPED_TRACE(moving ? "dynamic masks" : "no dynamic masks");
    testing::TempDir dir;
    auto trainer = MakeTrainer(/*surface=*/true, moving);
    RecordingPrior prior;
    Expansion expansion(SmallOptions(), /*seed=*/0, dir.path(), &prior);
    expansion.RunStep(trainer.get(), 1);
    ASSERT_EQ(prior.clips.size(), 2u);  // one per direction
    for (const PriorClip& clip : prior.clips) {
      if (!moving) {
        EXPECT_TRUE(clip.moving.empty());
        continue;
      }
      ASSERT_EQ(clip.moving.size(), clip.frames.size());
      for (std::size_t i = 0; i < clip.frames.size(); ++i) {
        const int count = cv::countNonZero(clip.moving[i]);
        // Landed pixels only, about the rectangle's area (12 degrees away).
        EXPECT_EQ(cv::countNonZero(clip.moving[i] & clip.masks[i]), 0);
        EXPECT_GT(count, kMovingRect.area() / 2) << i;
        EXPECT_LT(count, kMovingRect.area() * 3 / 2) << i;
      }
    }
  }
}

// Median warped depth over the landed pixels of every frame of `clips`.
double MedianLandedDepth(const std::vector<PriorClip>& clips) {
  std::vector<float> z;
  for (const PriorClip& clip : clips)
    for (std::size_t i = 0; i < clip.frames.size(); ++i)
      for (int p = 0; p < static_cast<int>(clip.depth[i].total()); ++p)
        if (!clip.masks[i].at<std::uint8_t>(p))
          z.push_back(clip.depth[i].at<float>(p));
  if (z.empty()) return 0.0;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  return z[z.size() / 2];
}

// The frames are warped with their own depth maps under WarpDepth::kGiven
// and with the Gaussians' rendered depth under kRendered; where a frame has
// no depth, kGiven falls back to the rendered depth.
TEST(ExpansionTest, WarpDepthChoosesTheFramesOwnDepthOrTheRenderedOne) {
  const auto run = [](float given_scale, WarpDepth warp_depth) {
    testing::TempDir dir;
    auto trainer = MakeTrainer(/*surface=*/true, false, given_scale);
    RecordingPrior prior;
    ExpansionOptions o = SmallOptions();
    o.warp_depth = warp_depth;
    Expansion expansion(o, /*seed=*/0, dir.path(), &prior);
    expansion.RunStep(trainer.get(), 1);
    EXPECT_EQ(prior.clips.size(), 2u);
    return prior.clips;
  };
  // The Gaussians lie at depth 3; the frames' depth maps say 4.5.
  const double rendered = MedianLandedDepth(run(1.5f, WarpDepth::kRendered));
  const double given = MedianLandedDepth(run(1.5f, WarpDepth::kGiven));
  EXPECT_NEAR(rendered, 3.0, 0.3);
  EXPECT_NEAR(given, 4.5, 0.45);
  // Frames without depth: the same warps as kRendered, pixel for pixel.
  const std::vector<PriorClip> a = run(0.0f, WarpDepth::kRendered);
  const std::vector<PriorClip> b = run(0.0f, WarpDepth::kGiven);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t c = 0; c < a.size(); ++c)
    for (std::size_t i = 0; i < a[c].depth.size(); ++i)
      EXPECT_EQ(cv::norm(a[c].depth[i], b[c].depth[i], cv::NORM_INF), 0.0)
          << c << " " << i;
  EXPECT_STREQ(WarpDepthName(WarpDepth::kGiven), "given");
  EXPECT_EQ(SmallOptions().ToJson().at("warp_depth"), "rendered");
}

TEST(ExpansionTest, PanoramaResultsComeFromTheFramesAndTheRefinedViews) {
  testing::TempDir dir;
  auto trainer = MakeTrainer();
  ConstantPrior prior;  // the steps fill magenta
  ExpansionOptions o = SmallOptions();
  o.gaussian_refinement = false;
  Expansion expansion(o, /*seed=*/0, dir.path(), &prior);
  EXPECT_THROW(
      expansion.PanoramicViews(trainer.get(), "early", {CameraAt(0)}, {0}),
      Error);
  expansion.RunStep(trainer.get(), 1);
  expansion.RunStep(trainer.get(), 2);
  prior.colour = cv::Vec3f(0, 1, 0);  // the panorama results fill green

  // Targets: a training camera, step 2's camera for f1 in direction 0, and
  // a camera looking away from everything the video saw.
  const TrainingView& f2 = trainer->views()[2];
  const ExpandedView* expanded = nullptr;
  for (const ExpandedView& v : expansion.cameras())
    if (v.e == 2 && v.m == 0 && v.name == "f1") expanded = &v;
  ASSERT_NE(expanded, nullptr);
  RasterCamera away = CameraAt(0.1f);
  away.rotation =
      Eigen::AngleAxisf(static_cast<float>(M_PI), Eigen::Vector3f::UnitY())
          .toRotationMatrix();
  std::string note = "unset";
  const std::vector<cv::Mat> views = expansion.PanoramicViews(
      trainer.get(), "test", {f2.camera, expanded->camera, away}, {2, 1, 1},
      &note);
  ASSERT_EQ(views.size(), 3u);
  EXPECT_EQ(note, "");
  const cv::Mat frame(kHeight, kWidth, CV_32FC3,
                      const_cast<float*>(f2.rgb.data()));
  // A training camera gets its frame back wherever the Gaussians give depth.
  RenderOutput out;
  trainer->Render(f2.camera, 2, &out);
  int same = 0, opaque = 0;
  for (int p = 0; p < kWidth * kHeight; ++p) {
    if (out.alpha[p] < 0.5f) continue;
    ++opaque;
    same += cv::norm(views[0].at<cv::Vec3f>(p) - frame.at<cv::Vec3f>(p)) < 1e-3;
  }
  EXPECT_GT(opaque, kWidth * kHeight / 2);
  EXPECT_GT(same, opaque * 95 / 100) << same << " of " << opaque;

  // Step 2's camera: what the frame did not reach comes from the refined
  // views (magenta), not from the prior now (green).
  const cv::Mat mask =
      ReadMask(dir.path() / "step_02" / "dir_0" / "mask" / "f1.png");
  ASSERT_GT(cv::countNonZero(mask), 0);
  int magenta = 0, green = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const cv::Vec3f c = views[1].at<cv::Vec3f>(y, x);
      if (!mask.at<std::uint8_t>(y, x)) continue;
      magenta += c == cv::Vec3f(1, 0, 1);
      green += c == cv::Vec3f(0, 1, 0);
    }
  }
  EXPECT_GT(magenta, cv::countNonZero(mask) / 2);
  EXPECT_EQ(green, 0);
  // Looking away from everything seen: the prior fills all of it.
  EXPECT_LT(MeanAbsDifference(views[2], cv::Mat(kHeight, kWidth, CV_32FC3,
                                                cv::Scalar(0, 1, 0))),
            1e-6);
}

TEST(ExpansionTest, OptionsAreChecked) {
  ExpansionOptions o;
  o.every = 0;
  EXPECT_THROW(o.Check(), Error);
  o = ExpansionOptions();
  o.refine_weight = -1;
  EXPECT_THROW(o.Check(), Error);
  o = ExpansionOptions();
  o.refine_outside_weight = -0.5;
  EXPECT_THROW(o.Check(), Error);
  GeometryPrior prior;
  EXPECT_THROW(
      Expansion(ExpansionOptions(), /*seed=*/0, "/tmp/unused", nullptr), Error);
}

}  // namespace
}  // namespace pano4d
