#include <cmath>
#include <map>
#include <random>

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "src/core/check.h"
#include "src/core/error.h"
#include "src/render/projection.h"
#include "src/render/rasterizer.h"

namespace pano4d {
namespace {

using Rd = RasterizerT<double>;

// A loss that weights every output: L = sum w_rgb rgb + w_d depth + w_a alpha;
// the weights are its gradient with respect to the outputs.
struct Weights : RenderGradientsT<double> {
  // Weights in [-1, 1] (depth in [-0.3, 0.3]) for every output of `out`.
  static Weights Random(const RenderOutputT<double>& out, std::mt19937& rng) {
    std::uniform_real_distribution<double> u(-1, 1);
    Weights w;
    for (std::size_t i = 0; i < out.rgb.size(); ++i) w.rgb.push_back(u(rng));
    for (std::size_t i = 0; i < out.depth.size(); ++i) {
      w.depth.push_back(0.3 * u(rng));
      w.alpha.push_back(u(rng));
    }
    return w;
  }
  double Loss(const RenderOutputT<double>& out) const {
    double l = 0;
    for (std::size_t i = 0; i < rgb.size(); ++i) l += rgb[i] * out.rgb[i];
    for (std::size_t i = 0; i < depth.size(); ++i)
      l += depth[i] * out.depth[i] + alpha[i] * out.alpha[i];
    return l;
  }
};

GaussianModelT<double> Scene(unsigned seed, int n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  GaussianModelT<double> m;
  m.Resize(n);
  for (int i = 0; i < n; ++i) {
    m.means[3 * i] = 0.25 * u(rng);
    m.means[3 * i + 1] = 0.2 * u(rng);
    m.means[3 * i + 2] = 2.0 + 0.5 * u(rng);
    for (int k = 0; k < 3; ++k) {
      m.log_scales[3 * i + k] = std::log(0.04 + 0.02 * u(rng));
      m.sh[3 * i + k] = 0.8 * u(rng);
    }
    for (int k = 0; k < 4; ++k) m.quats[4 * i + k] = u(rng);
    m.opacities[i] = 1.5 * u(rng);
  }
  return m;
}

RasterCameraT<double> SmallCamera() {
  RasterCameraT<double> camera;
  camera.width = 40;
  camera.height = 32;
  camera.fx = camera.fy = 60;
  camera.cx = 20;
  camera.cy = 16;
  return camera;
}

// The central difference of `loss` in entry k of `field`, on copies of
// `params` moved by +-h.
template <typename Params, typename Loss>
double CentralDifference(const Params& params,
                         std::vector<double> Params::*field, std::size_t k,
                         const Loss& loss) {
  const double h = 1e-6 * std::max(1.0, std::abs((params.*field)[k]));
  Params plus = params, minus = params;
  (plus.*field)[k] += h;
  (minus.*field)[k] -= h;
  return (loss(plus) - loss(minus)) / (2 * h);
}

// Counts the analytic gradients within 1e-3 (relative, with a floor) of
// the numeric ones, and reports the others.
struct Tally {
  int checked = 0, good = 0;
  void Add(double analytic, double numeric, const std::string& what) {
    ++checked;
    if (std::abs(numeric - analytic) / std::max(1e-3, std::abs(numeric)) <
        1e-3) {
      ++good;
    } else {
      std::cout << what << ": analytic " << analytic << " numeric " << numeric
                << "\n";
    }
  }
};

TEST(RasterizerBackwardTest, BlendGradientsMatchCentralDifferences) {
  RasterCameraT<double> camera = SmallCamera();
  RasterSettingsT<double> settings;
  settings.background = Eigen::Vector3d(0.2, 0.5, 0.1);
  Tally tally;
  for (unsigned seed : {1u, 2u, 3u}) {
    const GaussianModelT<double> model = Scene(seed, 24);
    Rd rasterizer;
    RasterStateT<double> state;
    RenderOutputT<double> out;
    rasterizer.Forward(model, camera, settings, &out, &state);
    const ProjectedGaussiansT<double> projected = state.projected;
    std::mt19937 rng(seed + 10);
    const Weights w = Weights::Random(out, rng);
    rasterizer.RasterizeForward(projected, camera, settings, &out, &state);
    ProjectedGradientsT<double> grad;
    rasterizer.RasterizeBackward(camera, settings, state, out, w, &grad);

    using Field = std::vector<double> ProjectedGaussiansT<double>::*;
    using GradField = std::vector<double> ProjectedGradientsT<double>::*;
    const std::vector<std::tuple<const char*, Field, GradField>> fields = {
        {"x", &ProjectedGaussiansT<double>::x, &ProjectedGradientsT<double>::x},
        {"y", &ProjectedGaussiansT<double>::y, &ProjectedGradientsT<double>::y},
        {"conic_a", &ProjectedGaussiansT<double>::conic_a,
         &ProjectedGradientsT<double>::conic_a},
        {"conic_b", &ProjectedGaussiansT<double>::conic_b,
         &ProjectedGradientsT<double>::conic_b},
        {"conic_c", &ProjectedGaussiansT<double>::conic_c,
         &ProjectedGradientsT<double>::conic_c},
        {"opacity", &ProjectedGaussiansT<double>::opacity,
         &ProjectedGradientsT<double>::opacity},
        {"r", &ProjectedGaussiansT<double>::r, &ProjectedGradientsT<double>::r},
        {"g", &ProjectedGaussiansT<double>::g, &ProjectedGradientsT<double>::g},
        {"b", &ProjectedGaussiansT<double>::b, &ProjectedGradientsT<double>::b},
        {"depth", &ProjectedGaussiansT<double>::depth,
         &ProjectedGradientsT<double>::depth},
    };
    for (std::size_t g = 0; g < projected.x.size(); ++g) {
      if (projected.radius[g] == 0) continue;
      for (const auto& [name, field, grad_field] : fields) {
        const double numeric = CentralDifference(
            projected, field, g, [&](const ProjectedGaussiansT<double>& q) {
              RenderOutputT<double> o;
              RasterStateT<double> s;
              Rd().RasterizeForward(q, camera, settings, &o, &s);
              return w.Loss(o);
            });
        tally.Add((grad.*grad_field)[g], numeric,
                  "seed " + std::to_string(seed) + " Gaussian " +
                      std::to_string(g) + " " + name);
      }
    }
  }
  EXPECT_EQ(tally.good, tally.checked);
  EXPECT_GT(tally.checked, 500);
  std::cout << tally.good << " of " << tally.checked
            << " blend gradients within 1e-3\n";
}

TEST(RasterizerBackwardTest, ModelGradientsMatchCentralDifferences) {
  RasterCameraT<double> camera = SmallCamera();
  // A rotated camera, so that W is not the identity.
  camera.rotation =
      Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 2, 0.5).normalized())
          .toRotationMatrix();
  camera.translation = Eigen::Vector3d(0.05, -0.03, 0.1);
  RasterSettingsT<double> settings;
  settings.background = Eigen::Vector3d(0.3, 0.1, 0.6);
  Tally tally;
  for (unsigned seed : {4u, 5u, 6u}) {
    GaussianModelT<double> model = Scene(seed, 16);
    model.sh_degree = 1;
    model.sh.assign(16 * 4 * 3, 0.0);
    std::mt19937 rng(seed + 20);
    std::uniform_real_distribution<double> u(-1, 1);
    for (double& c : model.sh) c = 0.4 * u(rng);
    Rd rasterizer;
    RasterStateT<double> state;
    RenderOutputT<double> out;
    rasterizer.Forward(model, camera, settings, &out, &state);
    const Weights w = Weights::Random(out, rng);
    GaussianGradientsT<double> grad;
    rasterizer.Backward(model, camera, settings, state, out, w, &grad);

    const std::vector<
        std::pair<std::string, std::vector<double> GaussianModelT<double>::*>>
        params = {{"means", &GaussianModelT<double>::means},
                  {"log_scales", &GaussianModelT<double>::log_scales},
                  {"quats", &GaussianModelT<double>::quats},
                  {"opacities", &GaussianModelT<double>::opacities},
                  {"sh", &GaussianModelT<double>::sh}};
    const std::map<std::string, const std::vector<double>*> analytic = {
        {"means", &grad.means},
        {"log_scales", &grad.log_scales},
        {"quats", &grad.quats},
        {"opacities", &grad.opacities},
        {"sh", &grad.sh}};
    for (const auto& [name, field] : params) {
      for (std::size_t k = 0; k < (model.*field).size(); ++k) {
        const double numeric = CentralDifference(
            model, field, k, [&](const GaussianModelT<double>& m) {
              RenderOutputT<double> o;
              Rd().Render(m, camera, settings, &o);
              return w.Loss(o);
            });
        tally.Add((*analytic.at(name))[k], numeric,
                  "seed " + std::to_string(seed) + " " + name + "[" +
                      std::to_string(k) + "]");
      }
    }
  }
  std::cout << tally.good << " of " << tally.checked
            << " model gradients within 1e-3\n";
  EXPECT_GE(tally.good, 0.99 * tally.checked);
  EXPECT_GT(tally.checked, 1000);
}

// A backward given another model or camera than its state's forward is
// refused as the bug in pano4d it is (InternalError, not an input Error),
// with both sizes named, instead of reading past the state.
TEST(RasterizerBackwardTest, AStateOfAnotherSizeIsRefusedNamingBothSizes) {
  const RasterCameraT<double> camera = SmallCamera();
  const RasterSettingsT<double> settings;
  Rd rasterizer;
  RasterStateT<double> state;
  RenderOutputT<double> out;
  const GaussianModelT<double> model = Scene(7, 16);
  rasterizer.Forward(model, camera, settings, &out, &state);
  RenderGradientsT<double> d_out;
  d_out.rgb.assign(out.rgb.size(), 1.0);
  GaussianGradientsT<double> grad;
  EXPECT_NO_THROW(
      rasterizer.Backward(model, camera, settings, state, out, d_out, &grad));
  const auto message = [&](const GaussianModelT<double>& m,
                           const RasterCameraT<double>& c,
                           const RenderGradientsT<double>& d) {
    try {
      rasterizer.Backward(m, c, settings, state, out, d, &grad);
    } catch (const InternalError& e) {
      EXPECT_NE(std::string(e.what()).find("a bug in pano4d"),
                std::string::npos);
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string larger = message(Scene(7, 20), camera, d_out);
  EXPECT_NE(larger.find("20 Gaussians"), std::string::npos) << larger;
  EXPECT_NE(larger.find("projected 16"), std::string::npos) << larger;
  RasterCameraT<double> wider = camera;
  wider.width = 48;
  const std::string other_camera = message(model, wider, d_out);
  EXPECT_NE(other_camera.find("40x32"), std::string::npos) << other_camera;
  EXPECT_NE(other_camera.find("48x32"), std::string::npos) << other_camera;
  RenderGradientsT<double> short_rgb;
  short_rgb.rgb.assign(out.rgb.size() - 3, 1.0);
  const std::string short_message = message(model, camera, short_rgb);
  EXPECT_NE(short_message.find(std::to_string(out.rgb.size() - 3)),
            std::string::npos)
      << short_message;
  EXPECT_NE(short_message.find(std::to_string(out.rgb.size())),
            std::string::npos)
      << short_message;
}

// The projection stage alone refuses a forward result of another size.
TEST(RasterizerBackwardTest, ProjectionBackwardRefusesAnotherModelsResult) {
  const RasterCameraT<double> camera = SmallCamera();
  const GaussianModelT<double> model = Scene(8, 16);
  ProjectedGaussiansT<double> projected;
  ProjectionForward(model, camera, &projected);
  ProjectedGradientsT<double> grad2d;
  grad2d.Assign(projected.size());
  GaussianGradientsT<double> grad;
  EXPECT_NO_THROW(ProjectionBackward(model, camera, projected, grad2d, &grad));
  try {
    ProjectionBackward(Scene(8, 20), camera, projected, grad2d, &grad);
    FAIL() << "a model of 20 Gaussians was taken for the forward's 16";
  } catch (const InternalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("20 Gaussians"), std::string::npos) << what;
    EXPECT_NE(what.find("projected 16"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace pano4d
