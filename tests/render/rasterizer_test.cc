#include "src/render/rasterizer.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <ostream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "src/core/camera.h"
#include "src/render/rasterize_to_pixels.h"
#include "src/render/sh.h"

namespace pano4d {
namespace {

constexpr float kC0 = static_cast<float>(kShC0);

RasterCamera TestCamera() {
  RasterCamera c;
  c.width = 128;
  c.height = 96;
  c.fx = c.fy = 100;
  c.cx = 64;
  c.cy = 48;
  return c;  // at the origin, looking down +z
}

// Appends one isotropic Gaussian with colour `rgb` (degree-0 SH).
void Add(GaussianModel* m, const Eigen::Vector3f& mean, float scale,
         float opacity, const Eigen::Vector3f& rgb,
         const Eigen::Vector4f& quat = {1, 0, 0, 0}) {
  const std::size_t i = m->size();
  m->Resize(i + 1);
  for (int k = 0; k < 3; ++k) {
    m->means[3 * i + k] = mean(k);
    m->log_scales[3 * i + k] = std::log(scale);
    m->sh[3 * i + k] = (rgb(k) - 0.5f) / kC0;
  }
  for (int k = 0; k < 4; ++k) m->quats[4 * i + k] = quat(k);
  m->opacities[i] = std::log(opacity / (1 - opacity));
}

bool AllFinite(const RenderOutput& out) {
  for (const auto* v : {&out.rgb, &out.depth, &out.alpha}) {
    for (const float x : *v) {
      if (!std::isfinite(x)) return false;
    }
  }
  return true;
}

TEST(RasterizerTest, SmallGaussianLandsWhereTheCameraProjects) {
  const RasterCamera camera = TestCamera();
  const Camera model_camera{
      CameraModelId::kPinhole, 128, 96, {100, 100, 64, 48}};
  for (const Eigen::Vector3f& point : {Eigen::Vector3f(0.1f, -0.05f, 2.0f),
                                       Eigen::Vector3f(-0.7f, 0.33f, 3.1f)}) {
    GaussianModel model;
    Add(&model, point, 0.01f, 0.5f, {1, 1, 1});
    Rasterizer rasterizer;
    RenderOutput out;
    rasterizer.Render(model, camera, {}, &out);
    double sum = 0, sx = 0, sy = 0;
    for (int y = 0; y < out.height; ++y) {
      for (int x = 0; x < out.width; ++x) {
        const double a = out.alpha[y * out.width + x];
        sum += a;
        sx += a * (x + 0.5);
        sy += a * (y + 0.5);
      }
    }
    const Eigen::Vector2d expected =
        *model_camera.Project(point.cast<double>());
    EXPECT_LT((Eigen::Vector2d(sx / sum, sy / sum) - expected).norm(), 0.1)
        << point.transpose();
  }
}

TEST(RasterizerTest, BlendsExactlyAtAPixelCentre) {
  // Mean on the centre of pixel (40, 30): there alpha = opacity exactly.
  const RasterCamera camera = TestCamera();
  const float z = 2.0f;
  const Eigen::Vector3f mean((40.5f - 64) / 100 * z, (30.5f - 48) / 100 * z, z);
  GaussianModel model;
  Add(&model, mean, 0.02f, 0.6f, {0.8f, 0.2f, 0.4f});
  RasterSettings settings;
  settings.background = {0.1f, 0.3f, 0.5f};
  Rasterizer rasterizer;
  RasterState state;
  RenderOutput out;
  rasterizer.Forward(model, camera, settings, &out, &state);
  const std::size_t p = 30 * 128 + 40;
  EXPECT_NEAR(out.alpha[p], 0.6f, 1e-5);
  EXPECT_NEAR(out.rgb[3 * p], 0.8f * 0.6f + 0.1f * 0.4f, 1e-5);
  EXPECT_NEAR(out.rgb[3 * p + 2], 0.4f * 0.6f + 0.5f * 0.4f, 1e-5);
  EXPECT_NEAR(out.depth[p], z, 1e-4);
  EXPECT_NEAR(state.final_transmittance[p], 0.4f, 1e-5);
}

TEST(RasterizerTest, NearerGaussianWinsWhateverTheArrayOrder) {
  const RasterCamera camera = TestCamera();
  GaussianModel a, b;
  Add(&a, {0, 0, 2}, 0.2f, 0.95f, {1, 0, 0});
  Add(&a, {0, 0, 4}, 0.4f, 0.95f, {0, 0, 1});
  Add(&b, {0, 0, 4}, 0.4f, 0.95f, {0, 0, 1});
  Add(&b, {0, 0, 2}, 0.2f, 0.95f, {1, 0, 0});
  Rasterizer r;
  RenderOutput out_a, out_b;
  r.Render(a, camera, {}, &out_a);
  r.Render(b, camera, {}, &out_b);
  EXPECT_EQ(out_a.rgb, out_b.rgb);
  const std::size_t centre = 48 * 128 + 64;
  EXPECT_GT(out_a.rgb[3 * centre], 0.9f);
  EXPECT_LT(out_a.rgb[3 * centre + 2], 0.1f);
}

GaussianModel RandomScene(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  GaussianModel m;
  m.sh_degree = 1;
  for (int i = 0; i < n; ++i) {
    Add(&m, {1.5f * u(rng), 1.0f * u(rng), 3.0f + u(rng)},
        0.03f * (1.5f + u(rng)), 0.5f + 0.4f * u(rng),
        {0.5f + 0.4f * u(rng), 0.5f + 0.4f * u(rng), 0.5f + 0.4f * u(rng)},
        {u(rng), u(rng), u(rng), u(rng)});
  }
  for (float& c : m.sh) c += 0.1f * u(rng);
  return m;
}

TEST(RasterizerTest, SameBytesWithOneAndTwoThreads) {
  const GaussianModel model = RandomScene(5000, 3);
  const RasterCamera camera = TestCamera();
  RenderOutput one, two;
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  Rasterizer().Render(model, camera, {}, &one);
  omp_set_num_threads(2);
  Rasterizer().Render(model, camera, {}, &two);
  omp_set_num_threads(threads);
  ASSERT_EQ(one.rgb.size(), two.rgb.size());
  EXPECT_EQ(std::memcmp(one.rgb.data(), two.rgb.data(),
                        one.rgb.size() * sizeof(float)),
            0);
  EXPECT_EQ(std::memcmp(one.depth.data(), two.depth.data(),
                        one.depth.size() * sizeof(float)),
            0);
  EXPECT_TRUE(AllFinite(one));
}

// The double instantiation (for finite-difference gradient checks) renders
// what the float one does.
TEST(RasterizerTest, DoubleAndFloatRenderTheSameImage) {
  const GaussianModel model = RandomScene(3000, 9);
  GaussianModelT<double> model_d;
  model_d.sh_degree = model.sh_degree;
  const auto widen = [](const std::vector<float>& v) {
    return std::vector<double>(v.begin(), v.end());
  };
  model_d.means = widen(model.means);
  model_d.log_scales = widen(model.log_scales);
  model_d.quats = widen(model.quats);
  model_d.opacities = widen(model.opacities);
  model_d.sh = widen(model.sh);
  const RasterCamera camera = TestCamera();
  RasterCameraT<double> camera_d;
  camera_d.width = camera.width;
  camera_d.height = camera.height;
  camera_d.fx = camera.fx;
  camera_d.fy = camera.fy;
  camera_d.cx = camera.cx;
  camera_d.cy = camera.cy;
  RenderOutput out;
  RenderOutputT<double> out_d;
  Rasterizer().Render(model, camera, {}, &out);
  RasterizerT<double>().Render(model_d, camera_d, {}, &out_d);
  double worst = 0;
  for (std::size_t i = 0; i < out.rgb.size(); ++i)
    worst = std::max(worst, std::abs(out.rgb[i] - out_d.rgb[i]));
  // A Gaussian at the 1/255 threshold may switch sides between precisions.
  EXPECT_LT(worst, 1e-2);
  double mean_diff = 0;
  for (std::size_t i = 0; i < out.rgb.size(); ++i)
    mean_diff += std::abs(out.rgb[i] - out_d.rgb[i]);
  EXPECT_LT(mean_diff / out.rgb.size(), 1e-5);
}

TEST(RasterizerTest, GradientsAreTheSameBytesWithOneAndTwoThreads) {
  const GaussianModel model = RandomScene(5000, 4);
  const RasterCamera camera = TestCamera();
  const auto gradients = [&](int threads) {
    omp_set_num_threads(threads);
    Rasterizer r;
    RasterState state;
    RenderOutput out;
    r.Forward(model, camera, {}, &out, &state);
    RenderGradients d_out;
    d_out.rgb.resize(out.rgb.size());
    for (std::size_t i = 0; i < d_out.rgb.size(); ++i)
      d_out.rgb[i] = std::sin(0.37f * i);
    d_out.depth = out.depth;
    GaussianGradients grad;
    r.Backward(model, camera, {}, state, out, d_out, &grad);
    return grad;
  };
  const int threads = omp_get_max_threads();
  const GaussianGradients one = gradients(1), two = gradients(2);
  omp_set_num_threads(threads);
  for (const auto& [a, b] : {std::pair{&one.means, &two.means},
                             {&one.log_scales, &two.log_scales},
                             {&one.quats, &two.quats},
                             {&one.opacities, &two.opacities},
                             {&one.sh, &two.sh}}) {
    ASSERT_EQ(a->size(), b->size());
    EXPECT_EQ(std::memcmp(a->data(), b->data(), a->size() * sizeof(float)), 0);
  }
  double norm = 0;
  for (const float v : one.means) norm += std::abs(v);
  EXPECT_GT(norm, 0.0);  // the gradients are not trivially zero
}

// The stiff and extreme cases of the issue, one test each: outputs and
// gradients finite, alpha in [0, 1].
struct StiffCase {
  const char* name;
  GaussianModel (*make)();
};

const StiffCase kStiffCases[] = {
    {"Scales1e-6To1e3OfTheScene",
     [] {
       GaussianModel m;
       for (const float s : {1e-6f, 1e-3f, 1.0f, 1e3f})
         Add(&m, {0, 0, 3}, s * 3, 0.5f, {1, 0, 0});
       return m;
     }},
    {"Anisotropy1e6",
     [] {
       GaussianModel m;
       Add(&m, {0, 0, 3}, 1.0f, 0.5f, {0, 1, 0});
       m.log_scales[0] = std::log(1e-6f);
       return m;
     }},
    {"NearPlaneAndBehindTheCamera",
     [] {
       GaussianModel m;
       Add(&m, {0, 0, 0.005f}, 0.5f, 0.9f, {1, 1, 1});  // straddles near
       Add(&m, {0, 0, -1}, 0.5f, 0.9f, {1, 1, 1});      // behind
       Add(&m, {0, 0, 0}, 0.5f, 0.9f, {1, 1, 1});       // at the centre
       return m;
     }},
    {"ImageBorder",
     [] {
       GaussianModel m;
       Add(&m, {(-3 - 64.0f) / 100 * 2, 0, 2}, 0.05f, 0.9f,
           {1, 1, 1});  // past the left border
       Add(&m, {(127.9f - 64) / 100 * 2, (95.9f - 48) / 100 * 2, 2}, 0.05f,
           0.9f, {1, 1, 1});  // on the bottom-right corner pixel
       return m;
     }},
    {"1e5GaussiansOnOnePixel",
     [] {
       GaussianModel m;
       for (int i = 0; i < 100000; ++i)
         Add(&m, {0, 0, 2 + 1e-5f * i}, 0.001f, 0.3f, {0.2f, 0.9f, 0.4f});
       return m;
     }},
    {"AllTransparent",
     [] {
       GaussianModel m;
       for (int i = 0; i < 50; ++i)
         Add(&m, {0.01f * i, 0, 3}, 0.1f, 1e-9f, {1, 1, 1});
       return m;
     }},
    {"ZeroQuaternion",
     [] {
       GaussianModel m;
       Add(&m, {0, 0, 3}, 0.1f, 0.5f, {1, 1, 1}, {0, 0, 0, 0});
       return m;
     }},
};

// Names the case in test listings (gtest would print the struct's bytes).
void PrintTo(const StiffCase& c, std::ostream* os) { *os << c.name; }

class StiffCaseTest : public testing::TestWithParam<StiffCase> {};

TEST_P(StiffCaseTest, OutputsAndGradientsStayFinite) {
  const GaussianModel model = GetParam().make();
  const RasterCamera camera = TestCamera();
  Rasterizer r;
  RasterState state;
  RenderOutput out;
  r.Forward(model, camera, {}, &out, &state);
  EXPECT_TRUE(AllFinite(out));
  for (const float a : out.alpha) {
    ASSERT_GE(a, 0.0f);
    ASSERT_LE(a, 1.0f);
  }
  RenderGradients d_out{std::vector<float>(out.rgb.size(), 1.0f), out.depth,
                        std::vector<float>(out.alpha.size(), 1.0f)};
  GaussianGradients grad;
  r.Backward(model, camera, {}, state, out, d_out, &grad);
  for (const auto* v : {&grad.means, &grad.log_scales, &grad.quats,
                        &grad.opacities, &grad.sh, &grad.means2d}) {
    for (const float x : *v) ASSERT_TRUE(std::isfinite(x));
  }
}

INSTANTIATE_TEST_SUITE_P(RasterizerTest, StiffCaseTest,
                         testing::ValuesIn(kStiffCases),
                         [](const testing::TestParamInfo<StiffCase>& info) {
                           std::string name = info.param.name;
                           std::replace(name.begin(), name.end(), '-',
                                        'm');  // gtest: [A-Za-z0-9_]
                           return name;
                         });

// Stiff cases whose result is known, not only finite.
TEST(RasterizerTest, AllTransparentSceneShowsTheBackground) {
  RasterSettings settings;
  settings.background = {0.2f, 0.4f, 0.6f};
  RenderOutput out;
  Rasterizer().Render(kStiffCases[5].make(), TestCamera(), settings, &out);
  EXPECT_NEAR(out.rgb[0], 0.2f, 1e-6);
  EXPECT_EQ(out.alpha[48 * 128 + 64], 0.0f);
}

TEST(RasterizerTest, ManyGaussiansOnOnePixelSaturateIt) {
  RenderOutput out;
  Rasterizer().Render(kStiffCases[4].make(), TestCamera(), {}, &out);
  const std::size_t centre = 48 * 128 + 64;
  // Opacity 0.3 each: transmittance falls under 1e-4 after about 26 of them.
  EXPECT_GT(out.alpha[centre], 1.0f - 2e-4f);
  EXPECT_NEAR(out.rgb[3 * centre + 1], 0.9f, 1e-3f);
  EXPECT_NEAR(out.depth[centre], 2.0f, 1e-3f);
}

// The blend's throughput counts (bench render): the backward walks the
// forward's pairs where no pixel stops, and no more where pixels saturate.
TEST(RasterizerTest, BackwardCountsTheForwardsPairsUpToTheStops) {
  GaussianModel faint;
  for (int i = 0; i < 5; ++i)
    Add(&faint, {0.05f * i, 0.02f * i, 2.0f + 0.1f * i}, 0.05f, 0.1f,
        {0.2f, 0.5f, 0.8f});
  const GaussianModel saturating = kStiffCases[4].make();
  const GaussianModel* models[] = {&faint, &saturating};
  for (const GaussianModel* m : models) {
    const GaussianModel& model = *m;
    Rasterizer rasterizer;
    RasterState state;
    RenderOutput out;
    rasterizer.Forward(model, TestCamera(), {}, &out, &state);
    RenderGradients d_out;
    d_out.rgb.assign(out.rgb.size(), 1e-3f);
    GaussianGradients grad;
    const RasterBackwardStats stats =
        rasterizer.Backward(model, TestCamera(), {}, state, out, d_out, &grad);
    ASSERT_GT(state.stats.pixel_evaluations, 0u);
    if (m == &faint) {
      EXPECT_EQ(stats.pixel_evaluations, state.stats.pixel_evaluations);
    } else {
      EXPECT_LT(stats.pixel_evaluations, state.stats.pixel_evaluations);
    }
  }
  const BlendCeiling c = ProbeBlendCeiling(1, 0.01);
  EXPECT_GT(c.forward_pairs_per_s, 0);
  EXPECT_GT(c.backward_pairs_per_s, 0);
  EXPECT_TRUE(std::isfinite(c.forward_pairs_per_s + c.backward_pairs_per_s));
}

}  // namespace
}  // namespace pano4d
