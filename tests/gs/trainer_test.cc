#include "src/gs/trainer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <random>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/core/check.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/hash.h"
#include "src/core/image.h"
#include "src/gs/checkpoint.h"
#include "src/gs/surface_loss.h"
#include "src/render/bench_scene.h"
#include "src/render/rasterizer.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

constexpr int kWidth = 64, kHeight = 48;

RasterCamera CameraAt(float x) {
  RasterCamera camera = BenchCamera(kWidth, kHeight);
  camera.translation = Eigen::Vector3f(-x, 0, 0);  // centre at (x, 0, 0)
  return camera;
}

// Renders `teacher` at each (camera, time) into training views with depth.
std::vector<TrainingView> RenderViews(const GaussianScene& teacher,
                                      const std::vector<float>& offsets,
                                      const std::vector<int>& times) {
  std::vector<TrainingView> views;
  Rasterizer rasterizer;
  GaussianModel composed;
  RenderOutput out;
  for (std::size_t i = 0; i < offsets.size(); ++i) {
    TrainingView v;
    v.name = "view" + std::to_string(i);
    v.time = times[i];
    v.camera = CameraAt(offsets[i]);
    teacher.ComposeAt(v.time, &composed);
    rasterizer.Render(composed, v.camera, {}, &out);
    v.rgb = out.rgb;
    v.depth = out.depth;
    for (std::size_t p = 0; p < v.depth.size(); ++p)
      if (out.alpha[p] < 0.5f) v.depth[p] = 0;
    views.push_back(std::move(v));
  }
  return views;
}

GaussianScene StaticTeacher() {
  GaussianScene scene;
  scene.statics = RandomViewFillingScene(1500, CameraAt(0), 3.0f, 11);
  scene.dynamics.sh_degree = scene.statics.sh_degree;
  scene.num_times = 1;
  return scene;
}

// The teacher, perturbed: colours and positions off, opacities lower.
GaussianScene Perturbed(GaussianScene scene, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal;
  for (GaussianModel* m : {&scene.statics, &scene.dynamics}) {
    for (float& v : m->means) v += 0.02f * normal(rng);
    for (float& v : m->sh) v += 0.5f * normal(rng);
    for (float& v : m->opacities) v -= 1.0f;
  }
  return scene;
}

TrainerOptions FastOptions(int iterations) {
  TrainerOptions o;
  o.iterations = iterations;
  o.strategy.densify_from = 1000000;  // no densification unless a test asks
  o.strategy.opacity_reset_every = 1000000;
  return o;
}

double MeanLoss(Trainer* trainer, int steps) {
  double sum = 0;
  for (int i = 0; i < steps; ++i) sum += trainer->Step().loss;
  return sum / steps;
}

TEST(TrainerTest, LossFallsOnAStaticScene) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.0f, 0.1f}, {0, 0, 0});
  Trainer trainer(Perturbed(teacher, 1), views, FastOptions(400), /*seed=*/0);
  const double first = MeanLoss(&trainer, 20);
  while (!trainer.Done()) trainer.Step();
  const double last = MeanLoss(&trainer, 20);
  EXPECT_LT(last, 0.3 * first) << "first " << first << " last " << last;
  EXPECT_FALSE(trainer.scene().has_motion());
}

TEST(TrainerTest, MotionBasesLearnAKnownTranslation) {
  // The dynamic Gaussians of the teacher move by (0.04 t, 0, 0); the
  // student starts with identity bases and must find the motion.
  GaussianScene teacher = StaticTeacher();
  teacher.num_times = 4;
  GaussianModel moving = RandomViewFillingScene(300, CameraAt(0), 4.0f, 5);
  for (std::size_t i = 0; i < moving.size(); ++i) {
    moving.means[i * 3 + 2] *= 0.5f;  // in front of the static ones
    moving.opacities[i] = 3.0f;
  }
  teacher.dynamics = moving;
  teacher.bases.Reset(1, 4);
  for (int t = 0; t < 4; ++t) teacher.bases.translation(0, t)[0] = 0.04f * t;
  teacher.logits.assign(moving.size(), 0.0f);
  const auto views =
      RenderViews(teacher, {0.0f, 0.05f, 0.0f, -0.05f}, {0, 1, 2, 3});

  GaussianScene student = teacher;
  student.bases.Reset(1, 4);
  TrainerOptions options = FastOptions(1500);
  options.smoothness_weight = 0;
  // From the identity the bases must travel the whole way: a learning rate
  // ten times the default, which expects bases initialised from tracks.
  options.lr_basis_translation = 1.6e-3;
  Trainer trainer(std::move(student), views, options, /*seed=*/0);
  const double first = MeanLoss(&trainer, 8);
  while (!trainer.Done()) trainer.Step();
  const double last = MeanLoss(&trainer, 8);
  EXPECT_LT(last, 0.5 * first);
  // Canonical means and bases share a gauge (a common shift moves both),
  // so motion is read relative to time 0.
  const float x0 = trainer.scene().bases.translation(0, 0)[0];
  for (int t = 1; t < 4; ++t) {
    const float x = trainer.scene().bases.translation(0, t)[0] - x0;
    EXPECT_NEAR(x, 0.04f * t, 0.01f) << "time " << t;
  }
}

// Learned flow (TrainingView::flows) carries the motion to the bases: the
// frames are one flat grey without depth, which say nothing about motion,
// and the
// student, grey too, learns the teacher's translation from the flow term
// alone; without flows its bases stay where they started.
TEST(TrainerTest, FlowPriorAloneTeachesTheBasesTheMotion) {
  // Every Gaussian moves up by kStep t; cameras step sideways (a motion
  // along their baseline could be explained by depth as well).
  constexpr float kStep = 0.04f;
  const std::vector<float> offsets = {0.0f, 0.05f, 0.0f, -0.05f};
  GaussianScene teacher;
  teacher.num_times = 4;
  teacher.dynamics = RandomViewFillingScene(400, CameraAt(0), 4.0f, 5);
  for (float& o : teacher.dynamics.opacities) o = 3.0f;
  std::fill(teacher.dynamics.sh.begin(), teacher.dynamics.sh.end(), 0.0f);
  teacher.statics.sh_degree = teacher.dynamics.sh_degree;
  teacher.bases.Reset(1, 4);
  for (int t = 0; t < 4; ++t) teacher.bases.translation(0, t)[1] = kStep * t;
  teacher.logits.assign(teacher.dynamics.size(), 0.0f);
  std::vector<TrainingView> views = RenderViews(teacher, offsets, {0, 1, 2, 3});
  for (TrainingView& v : views) std::fill(v.rgb.begin(), v.rgb.end(), 0.5f);
  std::vector<TrainingView> with_flow = views;
  // The flow of a point at the rendered depth z: f (moved - camera moved) / z.
  for (int a = 0; a < 4; ++a) {
    for (const int b : {a - 1, a + 1}) {
      if (b < 0 || b > 3) continue;
      TrainingView::Flow f;
      f.view = b;
      f.valid.assign(kWidth * kHeight, 0);
      f.flow.assign(kWidth * kHeight * 2, 0.0f);
      for (int p = 0; p < kWidth * kHeight; ++p) {
        const float z = views[a].depth[p];
        if (!(z > 0)) continue;
        f.valid[p] = 255;
        f.flow[2 * p] = -views[a].camera.fx * (offsets[b] - offsets[a]) / z;
        f.flow[2 * p + 1] = views[a].camera.fy * kStep * (b - a) / z;
      }
      with_flow[a].flows.push_back(std::move(f));
    }
  }
  // Nor any depth: its changes over time would teach the motion too.
  for (auto* list : {&views, &with_flow})
    for (TrainingView& v : *list) v.depth.clear();
  GaussianScene student = teacher;
  student.bases.Reset(1, 4);
  TrainerOptions options = FastOptions(300);
  options.smoothness_weight = 0;
  // Room to travel the whole way in 300 steps: without depth the scene's
  // extent, which scales the rate, is the cameras' spread (0.055).
  options.lr_basis_translation = 0.1;
  // The mean error of the learned translations; the flow term's sum.
  double flow_loss = 0;
  const auto motion_error = [&](std::vector<TrainingView> v) {
    Trainer trainer(student, std::move(v), options, /*seed=*/0);
    flow_loss = 0;
    while (!trainer.Done()) flow_loss += trainer.Step().flow;
    const float y0 = trainer.scene().bases.translation(0, 0)[1];
    double error = 0;
    for (int t = 1; t < 4; ++t)
      error +=
          std::abs(trainer.scene().bases.translation(0, t)[1] - y0 - kStep * t);
    return error / 3;
  };
  const double without = motion_error(views);  // no flows attached
  EXPECT_EQ(flow_loss, 0.0);
  const double with = motion_error(with_flow);
  EXPECT_GT(flow_loss, 0.0);
  EXPECT_GT(without, 0.05);  // about the whole motion, 0.08 on average
  // Most of the way in 300 steps (the motion spreads from the ends of the
  // clip inwards: the inner times' flows pull both ways at the start).
  EXPECT_LT(with, 0.35 * without) << "with " << with << " without " << without;
}

TEST(TrainerTest, AppearanceExplainsAViewsExposureInsteadOfTheGaussians) {
  // Three views of a static scene; the middle one was exposed 30% darker
  // with a blue cast. With appearance the transforms take the difference:
  // the Gaussians render the other views' colours, and the darker view's
  // transform holds the gain. Without, the Gaussians average it in.
  const GaussianScene teacher = StaticTeacher();
  auto views = RenderViews(teacher, {-0.1f, 0.0f, 0.1f}, {0, 0, 0});
  for (std::size_t p = 0; p < views[1].rgb.size(); p += 3) {
    views[1].rgb[p] *= 0.7f;
    views[1].rgb[p + 1] *= 0.7f;
    views[1].rgb[p + 2] = 0.7f * views[1].rgb[p + 2] + 0.05f;
  }
  // The mean signed error of view 0's render (the reference frame's
  // colours): the Gaussians' colour bias.
  const auto bias_on_view0 = [&](bool appearance) {
    TrainerOptions options = FastOptions(450);
    options.appearance = appearance;
    Trainer trainer(Perturbed(teacher, 4), views, options, /*seed=*/0);
    while (!trainer.Done()) trainer.Step();
    RenderOutput out;
    trainer.Render(views[0].camera, 0, &out);
    double sum = 0;
    for (std::size_t i = 0; i < out.rgb.size(); ++i)
      sum += out.rgb[i] - views[0].rgb[i];
    if (appearance) {
      const float* dark = trainer.appearance(1);
      EXPECT_LT(dark[0], 0.9f);  // red gain of the dark view
      EXPECT_LT(dark[4], 0.9f);  // green gain
      EXPECT_GT(dark[8] + dark[11], dark[4]) << "no blue cast";
      const float* reference = trainer.appearance(0);
      EXPECT_EQ(std::vector<float>(reference, reference + kAppearanceWidth),
                IdentityAppearance());
    }
    return sum / out.rgb.size();
  };
  const double with = bias_on_view0(true), without = bias_on_view0(false);
  EXPECT_LT(without, -0.005);  // darkened by the average
  EXPECT_LT(std::abs(with), 0.5 * std::abs(without))
      << "with " << with << " without " << without;
}

TEST(TrainerTest, NonFiniteGradientIsSkippedLoggedAndTrainingGoesOn) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.1f}, {0, 0});
  Trainer trainer(Perturbed(teacher, 2), views, FastOptions(100), /*seed=*/0);
  int calls = 0;
  trainer.gradient_hook = [&](GaussianGradients* g) {
    if (++calls == 3) {
      g->means[7 * 3] = std::numeric_limits<float>::quiet_NaN();
      g->sh[9 * 3 + 1] = std::numeric_limits<float>::infinity();
    }
  };
  for (int i = 0; i < 2; ++i) trainer.Step();
  const StepReport third = trainer.Step();
  EXPECT_FALSE(third.skipped_step);
  EXPECT_EQ(trainer.skipped_rows_total(), 2);
  // The poisoned Gaussians got no gradient this step (only Adam's momentum
  // moved them): every parameter stays finite.
  for (float v : trainer.scene().statics.means) ASSERT_TRUE(std::isfinite(v));
  for (float v : trainer.scene().statics.sh) ASSERT_TRUE(std::isfinite(v));
  const double later = MeanLoss(&trainer, 50);
  EXPECT_TRUE(std::isfinite(later));
}

TEST(TrainerTest, CheckpointResumesBitForBit) {
  GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.0f, 0.1f}, {0, 0, 0});
  TrainerOptions options = FastOptions(60);
  options.strategy.densify_from =
      10;  // densification and pruning inside the run
  options.strategy.densify_every = 10;
  options.strategy.densify_gradient = 1e-5;
  options.strategy.opacity_reset_every = 25;
  testing::TempDir dir;
  const auto path = dir.path() / "fit.ckpt";

  Trainer straight(Perturbed(teacher, 3), views, options, /*seed=*/0);
  for (int i = 0; i < 30; ++i) straight.Step();
  straight.SaveCheckpoint(path);
  while (!straight.Done()) straight.Step();

  Trainer resumed(ReadCheckpointScene(path), views, options, /*seed=*/0);
  resumed.LoadCheckpoint(path);
  EXPECT_EQ(resumed.iteration(), 30);
  while (!resumed.Done()) resumed.Step();
  EXPECT_GT(straight.densified_total(), 0);
  EXPECT_EQ(straight.scene().statics.means, resumed.scene().statics.means);
  EXPECT_EQ(straight.scene().statics.sh, resumed.scene().statics.sh);
  EXPECT_EQ(straight.scene().statics.opacities,
            resumed.scene().statics.opacities);
}

TEST(TrainerTest, CheckpointOfOtherOptionsOrTruncatedIsRefused) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {0.0f}, {0});
  testing::TempDir dir;
  const auto path = dir.path() / "fit.ckpt";
  Trainer a(teacher, views, FastOptions(10), /*seed=*/0);
  a.Step();
  a.SaveCheckpoint(path);
  Trainer b(teacher, views, FastOptions(20), /*seed=*/0);
  EXPECT_THROW(b.LoadCheckpoint(path), Error);
  const auto bytes = ReadFileBytes(path);
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size() / 2));
  }
  try {
    ReadCheckpointScene(path);
    FAIL() << "a truncated checkpoint was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("fit.ckpt"), std::string::npos);
  }
}

// `bytes` (a version 2 checkpoint) with `edit` applied to its header text
// and the checksum recomputed, as a careful hand would leave it.
std::vector<std::uint8_t> WithHeaderEdited(
    const std::vector<std::uint8_t>& bytes,
    const std::function<void(std::string*)>& edit) {
  const std::string file(bytes.begin(), bytes.end());
  std::uint64_t length = 0;
  std::memcpy(&length, file.data() + 8, 8);
  std::string header = file.substr(16, length);
  edit(&header);
  const auto word = [](std::uint64_t value) {
    return std::string(reinterpret_cast<const char*>(&value), 8);
  };
  std::string out = file.substr(0, 8) + word(header.size()) + header +
                    file.substr(16 + length, file.size() - 24 - length);
  Hash64 sum;
  sum.Add(out);
  out += word(sum.value());
  return std::vector<std::uint8_t>(out.begin(), out.end());
}

// The message of the Error that `load` throws ("" when none).
std::string ErrorOf(const std::function<void()>& load) {
  try {
    load();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(TrainerTest, CheckpointOfAnotherSceneCorruptOrEditedIsRefusedByName) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.1f}, {0, 0});
  Trainer a(teacher, views, FastOptions(10), /*seed=*/0);
  for (int i = 0; i < 3; ++i) a.Step();
  testing::TempDir dir;
  a.SaveCheckpoint(dir / "a.ckpt");
  const std::vector<std::uint8_t> bytes = ReadFileBytes(dir / "a.ckpt");
  const auto load = [&](const std::vector<TrainingView>& v,
                        std::vector<std::uint8_t> b) {
    return ErrorOf([&] {
      Trainer t(teacher, v, FastOptions(10), /*seed=*/0);
      t.LoadCheckpoint(std::move(b), "a.ckpt");
    });
  };
  EXPECT_EQ(load(views, bytes), "");

  // The same frame names over other pixels: another scene.
  std::vector<TrainingView> other = views;
  other[1].rgb[5] += 0.25f;
  EXPECT_NE(load(other, bytes).find("a.ckpt: field 'scene'"), std::string::npos)
      << load(other, bytes);
  other = views;
  other[0].camera.translation.x() += 0.01f;
  EXPECT_NE(load(other, bytes).find("'scene'"), std::string::npos);

  // A flipped bit anywhere: the checksum.
  for (std::size_t at : {std::size_t{20}, bytes.size() / 2, bytes.size() - 9}) {
    std::vector<std::uint8_t> flipped = bytes;
    flipped[at] ^= 0x10;
    EXPECT_NE(load(views, flipped).find("checksum"), std::string::npos) << at;
  }
  // Cut short: named as such, not a crash.
  EXPECT_NE(
      load(views, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 12))
          .find("too short"),
      std::string::npos);

  // A header edited with its checksum made to match: the iteration is
  // bounded by the run's, the optimisers' steps by the iteration.
  const auto edited = [&](const std::string& from, const std::string& to) {
    return WithHeaderEdited(bytes, [&](std::string* h) {
      const std::size_t at = h->find(from);
      ASSERT_NE(at, std::string::npos) << from << " in " << *h;
      h->replace(at, from.size(), to);
    });
  };
  EXPECT_EQ(load(views, edited("\"iteration\":3", "\"iteration\":4")), "");
  EXPECT_NE(load(views, edited("\"iteration\":3", "\"iteration\":1000000000"))
                .find("'iteration' = 1000000000"),
            std::string::npos);
  EXPECT_NE(load(views, edited("\"static\":3", "\"static\":-2"))
                .find("adam_steps.static"),
            std::string::npos);
  EXPECT_NE(
      load(views, edited("\"scene\":\"", "\"scene\":\"0")).find("'scene'"),
      std::string::npos);
}

// The checkpoint as plain state: read back and written again it is the same
// file; with one optimiser moment a row short (what the fuzzer made) the
// resume is refused naming the file and the optimiser, not taken for a bug.
TEST(TrainerTest, CheckpointStateRoundTripsAndShortMomentsAreRefused) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.1f}, {0, 0});
  Trainer a(teacher, views, FastOptions(10), /*seed=*/0);
  for (int i = 0; i < 3; ++i) a.Step();
  testing::TempDir dir;
  a.SaveCheckpoint(dir / "a.ckpt");
  const CheckpointReader reader(dir / "a.ckpt");
  CheckpointState state = reader.State();
  EXPECT_EQ(state.iteration, 3);
  EXPECT_EQ(state.views,
            (std::vector<std::string>{views[0].name, views[1].name}));
  std::vector<std::vector<float>> arrays;
  for (const nlohmann::json& entry : reader.header().at("arrays")) {
    arrays.emplace_back();
    reader.Read(entry.at("name"), &arrays.back());
  }
  std::size_t i = 0;
  for (const nlohmann::json& entry : reader.header().at("arrays"))
    state.arrays.push_back({entry.at("name"), &arrays[i++]});
  WriteCheckpoint(dir / "b.ckpt", state);
  EXPECT_EQ(ReadFileBytes(dir / "b.ckpt"), ReadFileBytes(dir / "a.ckpt"));

  for (std::size_t k = 0; k < state.arrays.size(); ++k) {
    if (state.arrays[k].first == "adam.static.means.v") arrays[k].resize(3);
  }
  WriteCheckpoint(dir / "short.ckpt", state);
  Trainer b(teacher, views, FastOptions(10), /*seed=*/0);
  const std::string error =
      ErrorOf([&] { b.LoadCheckpoint(dir / "short.ckpt"); });
  EXPECT_NE(error.find("short.ckpt"), std::string::npos) << error;
  EXPECT_NE(error.find("adam.static"), std::string::npos) << error;
}

// A version-1 checkpoint (no checksum) is still read for its scene, and its
// Gaussians are checked like any other scene's: a zero quaternion is refused
// naming the file instead of reaching an exported PLY.
TEST(TrainerTest, AVersionOneCheckpointWithAZeroQuaternionIsRefused) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.1f}, {0, 0});
  Trainer a(teacher, views, FastOptions(10), /*seed=*/0);
  a.Step();
  testing::TempDir dir;
  a.SaveCheckpoint(dir / "a.ckpt");
  std::vector<std::uint8_t> v1 = ReadFileBytes(dir / "a.ckpt");
  v1.resize(v1.size() - 8);  // version 1 has no checksum
  v1[7] = '1';
  EXPECT_EQ(ErrorOf([&] { ReadCheckpointScene(v1, "v1.ckpt"); }), "");

  std::uint64_t length = 0;
  std::memcpy(&length, v1.data() + 8, 8);
  const nlohmann::json header = nlohmann::json::parse(
      std::string(v1.begin() + 16, v1.begin() + 16 + length));
  std::size_t offset = 16 + length;
  for (const nlohmann::json& array : header.at("arrays")) {
    if (array.at("name") == "static.quats") break;
    offset += array.at("count").get<std::size_t>() * sizeof(float);
  }
  std::fill(v1.begin() + offset, v1.begin() + offset + 4 * sizeof(float), 0);
  const std::string error =
      ErrorOf([&] { ReadCheckpointScene(v1, "v1.ckpt"); });
  EXPECT_NE(error.find("v1.ckpt"), std::string::npos) << error;
  EXPECT_NE(error.find("quat"), std::string::npos) << error;
}

TEST(TrainerTest, DensificationRespectsTheCap) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.1f}, {0, 0});
  TrainerOptions options = FastOptions(40);
  options.strategy.densify_from = 5;
  options.strategy.densify_every = 5;
  options.strategy.densify_gradient = 1e-7;  // everything qualifies
  options.strategy.prune_opacity = 0;
  options.strategy.max_gaussians =
      static_cast<std::int64_t>(teacher.size()) + 100;
  Trainer trainer(Perturbed(teacher, 4), views, options, /*seed=*/0);
  while (!trainer.Done()) trainer.Step();
  EXPECT_LE(static_cast<std::int64_t>(trainer.scene().size()),
            options.strategy.max_gaussians);
  EXPECT_GT(trainer.densified_total(), 0);
}

// The expansion's Gaussians join the static ones with fresh optimiser state,
// up to the cap; training then goes on over all of them, and a checkpoint
// written after the addition resumes.
TEST(TrainerTest, AddedStaticGaussiansTrainAndRespectTheCap) {
  testing::TempDir dir;
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.1f}, {0, 0});
  TrainerOptions options = FastOptions(30);
  options.strategy.densify_from = 10;  // statistics must follow the added rows
  options.strategy.densify_every = 10;
  options.strategy.max_gaussians =
      static_cast<std::int64_t>(teacher.size()) + 50;
  Trainer trainer(Perturbed(teacher, 5), views, options, /*seed=*/0);
  for (int i = 0; i < 5; ++i) trainer.Step();
  const GaussianModel extra = RandomViewFillingScene(80, CameraAt(0), 4.0f, 9);
  const std::size_t before = trainer.scene().statics.size();
  EXPECT_EQ(trainer.AddStaticGaussians(extra), 50);  // 30 over the cap
  ASSERT_EQ(trainer.scene().statics.size(), before + 50);
  EXPECT_EQ(trainer.scene().statics.means[before * 3], extra.means[0]);
  EXPECT_EQ(trainer.AddStaticGaussians(extra), 0);  // at the cap
  while (!trainer.Done()) {
    const StepReport r = trainer.Step();
    ASSERT_TRUE(std::isfinite(r.loss));
    EXPECT_EQ(r.skipped_rows, 0);
  }
  for (float v : trainer.scene().statics.means) ASSERT_TRUE(std::isfinite(v));
  trainer.SaveCheckpoint(dir / "a.ckpt");
  Trainer resumed(ReadCheckpointScene(dir / "a.ckpt"), views, options,
                  /*seed=*/0);
  resumed.LoadCheckpoint(dir / "a.ckpt");
  EXPECT_EQ(resumed.scene().statics.size(), trainer.scene().statics.size());
  GaussianModel wrong_degree = extra;
  wrong_degree.sh_degree = extra.sh_degree + 1;
  EXPECT_THROW(trainer.AddStaticGaussians(wrong_degree), InternalError);
}

// A static Gaussian may not grow wider than max_static_scale_pixels at the
// median depth: after a step every static scale is within it, and without
// the clamp (0) the wide ones stay wide.
TEST(TrainerTest, StaticScalesAreClampedToThePixelBound) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.1f}, {0, 0});
  GaussianScene student = Perturbed(teacher, 6);
  for (std::size_t i = 0; i < 20 * 3; ++i)
    student.statics.log_scales[i] = std::log(1.0f);  // far wider than 4 px
  std::vector<float> medians;
  for (const TrainingView& v : views) {
    std::vector<float> d;
    for (float z : v.depth)
      if (z > 0) d.push_back(z);
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    medians.push_back(d[d.size() / 2]);
  }
  std::nth_element(medians.begin(), medians.begin() + medians.size() / 2,
                   medians.end());
  const float bound = 4.0f * medians[medians.size() / 2] /
                      (0.5f * (views[0].camera.fx + views[0].camera.fy));
  ASSERT_LT(bound, 0.5f);

  TrainerOptions options = FastOptions(3);
  options.max_static_scale_pixels = 4.0;
  Trainer clamped(student, views, options, /*seed=*/0);
  clamped.Step();
  for (float v : clamped.scene().statics.log_scales)
    ASSERT_LE(v, std::log(bound) + 1e-5f);

  options.max_static_scale_pixels = 0.0;
  Trainer free(student, views, options, /*seed=*/0);
  free.Step();
  EXPECT_GT(free.scene().statics.log_scales[0], std::log(0.9f));
}

// The expansion's free-space carving removes static rows: the dynamic ones,
// the optimiser state and the densification statistics follow, and the run
// goes on and resumes.
TEST(TrainerTest, RemovedStaticGaussiansLeaveTheRestTraining) {
  testing::TempDir dir;
  GaussianScene teacher = StaticTeacher();
  teacher.num_times = 2;
  teacher.dynamics = RandomViewFillingScene(100, CameraAt(0), 4.0f, 5);
  teacher.bases.Reset(1, 2);
  teacher.logits.assign(teacher.dynamics.size(), 0.0f);
  const auto views = RenderViews(teacher, {-0.1f, 0.1f}, {0, 1});
  TrainerOptions options = FastOptions(30);
  options.strategy.densify_from =
      10;  // statistics must follow the removed rows
  options.strategy.densify_every = 10;
  options.strategy.densify_gradient = 1e-6;  // densify plenty
  Trainer trainer(Perturbed(teacher, 5), views, options, /*seed=*/0);
  for (int i = 0; i < 5; ++i) trainer.Step();
  const GaussianModel statics = trainer.scene().statics;
  const GaussianModel dynamics = trainer.scene().dynamics;
  std::vector<std::uint8_t> keep(statics.size(), 1);
  for (std::size_t i = 0; i < keep.size(); i += 3) keep[i] = 0;
  const std::int64_t pruned = trainer.pruned_total();
  const std::int64_t removed = trainer.RemoveStaticGaussians(keep);
  EXPECT_EQ(removed, static_cast<std::int64_t>((statics.size() + 2) / 3));
  EXPECT_EQ(trainer.pruned_total(), pruned + removed);
  ASSERT_EQ(trainer.scene().statics.size(), statics.size() - removed);
  EXPECT_EQ(trainer.scene().statics.means[0], statics.means[3]);  // row 1
  EXPECT_EQ(trainer.scene().dynamics.means, dynamics.means);
  EXPECT_EQ(trainer.RemoveStaticGaussians(
                std::vector<std::uint8_t>(trainer.scene().statics.size(), 1)),
            0);
  while (!trainer.Done()) {
    const StepReport r = trainer.Step();
    ASSERT_TRUE(std::isfinite(r.loss));
    EXPECT_EQ(r.skipped_rows, 0);
  }
  EXPECT_GT(trainer.densified_total(), 0);
  trainer.SaveCheckpoint(dir / "a.ckpt");
  Trainer resumed(ReadCheckpointScene(dir / "a.ckpt"), views, options,
                  /*seed=*/0);
  resumed.LoadCheckpoint(dir / "a.ckpt");
  EXPECT_EQ(resumed.scene().statics.size(), trainer.scene().statics.size());
  EXPECT_THROW(trainer.RemoveStaticGaussians(std::vector<std::uint8_t>(3, 1)),
               InternalError);
}

TEST(TrainerTest, ExtraViewLossIsAddedThroughTheHook) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {0.0f}, {0});
  Trainer trainer(teacher, views, FastOptions(5), /*seed=*/0);
  ExtraView extra;
  extra.camera = CameraAt(0.2f);
  extra.target.assign(kWidth * kHeight * 3, 1.0f);  // white
  extra.mask.assign(kWidth * kHeight, 0);
  for (int p = 0; p < kWidth * kHeight / 2; ++p) extra.mask[p] = kMaskOn;
  extra.weight = 0.1;
  trainer.extra_view = [&](std::int64_t) { return &extra; };
  const StepReport r = trainer.Step();
  EXPECT_GT(r.extra, 0.0);
  EXPECT_NEAR(r.loss,
              r.l1 * 0.8 + (1 - r.ssim) * 0.2 + r.depth + r.normal + r.extra,
              1e-6);
}

TEST(TrainerTest, ExtraViewOutsideWeightAddsThePixelsOutsideTheMask) {
  // The same first step (the loss is taken before any update) with the
  // pixels outside the mask weighted 0, 1 and 3: the loss is linear in the
  // weight, 0 is the masked loss, and the outside pixels count.
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {0.0f}, {0});
  ExtraView extra;
  extra.camera = CameraAt(0.2f);
  extra.target.assign(kWidth * kHeight * 3, 1.0f);  // white
  extra.mask.assign(kWidth * kHeight, 0);
  for (int p = 0; p < kWidth * kHeight / 2; ++p) extra.mask[p] = kMaskOn;
  const auto first_step = [&](double outside) {
    ExtraView e = extra;
    e.outside_weight = outside;
    Trainer trainer(teacher, views, FastOptions(5), /*seed=*/0);
    trainer.extra_view = [&](std::int64_t) { return &e; };
    return trainer.Step().extra;
  };
  const double masked = first_step(0.0), one = first_step(1.0),
               three = first_step(3.0);
  EXPECT_GT(one, masked * 1.05);
  EXPECT_NEAR(three - masked, 3.0 * (one - masked), 1e-9);
  // An empty mask adds nothing, whatever the outside weight.
  extra.mask.assign(kWidth * kHeight, 0);
  EXPECT_EQ(first_step(1.0), 0.0);
}

TEST(TrainerTest, NormalFlatnessTermFlattensGaussiansAlongTheDepthNormals) {
  const GaussianScene teacher = StaticTeacher();
  const auto views = RenderViews(teacher, {-0.1f, 0.0f, 0.1f}, {0, 0, 0});
  // The share of variance along the depth normals in the middle view.
  const auto across = [&](const Trainer& t) {
    std::vector<float> d_ls(t.scene().statics.size() * 3, 0.0f),
        d_q(t.scene().statics.size() * 4, 0.0f);
    return NormalFlatnessLoss(t.scene().statics, views[1].camera,
                              views[1].depth, 1.0, 0.03, &d_ls, &d_q);
  };
  TrainerOptions off = FastOptions(150), on = FastOptions(150);
  off.normal_weight = 0;
  on.normal_weight = 1.0;
  Trainer without(Perturbed(teacher, 3), views, off, /*seed=*/0);
  Trainer with(Perturbed(teacher, 3), views, on, /*seed=*/0);
  const double start = across(with).loss;
  StepReport last_off, last_on;
  while (!with.Done()) {
    last_off = without.Step();
    last_on = with.Step();
  }
  EXPECT_EQ(last_off.normal, 0.0);
  EXPECT_GT(last_on.normal, 0.0);
  const NormalFlatness a = across(without), b = across(with);
  ASSERT_GT(b.gaussians, 30);
  EXPECT_LT(b.loss, 0.5 * a.loss)
      << "start " << start << " without " << a.loss << " with " << b.loss;
  EXPECT_LT(b.loss, 0.5 * start);
}

TEST(TrainerTest, HiddenDepthTermBringsHiddenMovingGaussiansToTheSurface) {
  // An opaque moving plate in front of a static background, and 60 more
  // moving Gaussians 30% behind the plate: no view sees them, so only the
  // hidden-depth term moves them.
  GaussianScene teacher = StaticTeacher();
  teacher.num_times = 2;
  // Moves a Gaussian along its ray (from the origin) to depth z, so that it
  // keeps its footprint.
  const auto to_depth = [](GaussianModel* m, std::size_t i, float z) {
    const float k = z / m->means[i * 3 + 2];
    for (int j = 0; j < 3; ++j) m->means[i * 3 + j] *= k;
    for (int j = 0; j < 3; ++j) m->log_scales[i * 3 + j] += std::log(k);
  };
  GaussianModel plate = RandomViewFillingScene(800, CameraAt(0), 5.0f, 7);
  for (std::size_t i = 0; i < plate.size(); ++i) {
    to_depth(&plate, i, 1.5f);
    plate.opacities[i] = 6.0f;
  }
  teacher.dynamics = plate;
  teacher.bases.Reset(1, 2);
  teacher.bases.translation(0, 1)[0] = 0.02f;
  teacher.logits.assign(plate.size(), 0.0f);
  auto views = RenderViews(teacher, {-0.05f, 0.05f}, {0, 1});
  // The plate's silhouette is the dynamic mask.
  GaussianScene plate_only = teacher;
  plate_only.statics = GaussianModel();
  plate_only.statics.sh_degree = teacher.statics.sh_degree;
  const auto masks = RenderViews(plate_only, {-0.05f, 0.05f}, {0, 1});
  for (std::size_t v = 0; v < views.size(); ++v) {
    views[v].dynamic.assign(views[v].depth.size(), 0);
    for (std::size_t p = 0; p < views[v].depth.size(); ++p)
      views[v].dynamic[p] = masks[v].depth[p] > 0 ? kMaskOn : 0;
  }

  GaussianScene student = teacher;
  GaussianModel hidden = RandomViewFillingScene(60, CameraAt(0), 1.0f, 9);
  std::vector<std::uint32_t> rows(hidden.size());
  for (std::size_t i = 0; i < hidden.size(); ++i) {
    rows[i] = static_cast<std::uint32_t>(i);
    // Inside the plate's middle, where every view shows the plate.
    to_depth(&hidden, i, 1.5f * 1.3f);
    hidden.means[i * 3] *= 0.4f;
    hidden.means[i * 3 + 1] *= 0.4f;
  }
  AppendGaussianRows(hidden, rows, &student.dynamics);
  student.logits.assign(student.dynamics.size(), 0.0f);

  const auto hidden_count = [&](const Trainer& t) {
    GaussianModel composed;
    t.scene().ComposeAt(0, &composed);
    std::vector<float> d_means(composed.size() * 3, 0.0f);
    return HiddenDepthLoss(composed, t.scene().statics.size(), views[0].camera,
                           views[0].depth, views[0].dynamic, 1.0, 0.1,
                           &d_means);
  };
  TrainerOptions off = FastOptions(200), on = FastOptions(200);
  off.hidden_weight = 0;
  on.hidden_weight = 1.0;
  on.hidden_thickness = 0.1;
  // Means move 30x faster than by default, so that 200 steps (the rate
  // decaying 100x) can carry them the 0.3 they must go.
  off.lr_mean = on.lr_mean = 5e-3;
  Trainer without(student, views, off, /*seed=*/0);
  Trainer with(student, views, on, /*seed=*/0);
  const HiddenDepth start = hidden_count(with);
  ASSERT_GE(start.hidden, 55);
  StepReport last_off, last_on;
  while (!with.Done()) {
    last_off = without.Step();
    last_on = with.Step();
  }
  EXPECT_EQ(last_off.hidden, 0.0);
  const HiddenDepth a = hidden_count(without), b = hidden_count(with);
  EXPECT_GE(a.hidden, 55) << "without the term nothing moves them";
  EXPECT_LE(b.hidden, 5) << "start " << start.hidden << " with " << b.hidden;
}

}  // namespace
}  // namespace pano4d
