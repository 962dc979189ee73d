// `pano4d bench stability`: the stiff and extreme suite (bench.h). Every
// case counts the non-finite values it produced (which must be 0) and
// reports its metrics; the fits train through the fit controller, with the
// fit's defaults.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include <opencv2/core.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/workspace.h"
#include "src/datasets/synth_generate.h"
#include "src/gs/checkpoint.h"
#include "src/lab/bench.h"
#include "src/pano/trajectory.h"
#include "src/pano/warp.h"
#include "src/pipeline/depth.h"
#include "src/pipeline/fit.h"
#include "src/render/bench_scene.h"
#include "src/render/panorama.h"
#include "src/render/rasterizer.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// Counts values and the non-finite ones among them.
struct Count {
  std::int64_t values = 0;
  std::int64_t non_finite = 0;
  void Add(double v) {
    ++values;
    non_finite += !std::isfinite(v);
  }
  template <typename T>
  void Add(const std::vector<T>& v) {
    for (const T& x : v) Add(static_cast<double>(x));
  }
  void Add(const cv::Mat& m) {
    cv::Mat d;
    (m.isContinuous() ? m : m.clone()).reshape(1).convertTo(d, CV_64F);
    for (auto it = d.begin<double>(); it != d.end<double>(); ++it) Add(*it);
  }
  void Add(const GaussianModel& g) {
    Add(g.means);
    Add(g.log_scales);
    Add(g.quats);
    Add(g.opacities);
    Add(g.sh);
  }
};

struct CaseResult {
  explicit CaseResult(std::string n) : name(std::move(n)) {}
  std::string name;
  Count count;
  nlohmann::json metrics = nlohmann::json::object();
  double seconds = 0;
};

// Forward and backward of `model` at `camera` with every pixel's colour
// gradient 1: outputs and gradients go into `count`; returns the rendered
// (not culled) Gaussians.
int RenderBothWays(const GaussianModel& model, const RasterCamera& camera,
                   Count* count, double* mean_alpha) {
  Rasterizer r;
  RasterState state;
  RenderOutput out;
  r.Forward(model, camera, RasterSettings{}, &out, &state);
  count->Add(out.rgb);
  count->Add(out.depth);
  count->Add(out.alpha);
  RenderGradients d_out;
  d_out.rgb.assign(out.rgb.size(), 1.0f);
  GaussianGradients g;
  r.Backward(model, camera, RasterSettings{}, state, out, d_out, &g);
  count->Add(g.means);
  count->Add(g.log_scales);
  count->Add(g.quats);
  count->Add(g.opacities);
  count->Add(g.sh);
  double alpha = 0;
  for (float a : out.alpha) alpha += a;
  *mean_alpha = alpha / std::max<std::size_t>(1, out.alpha.size());
  int rendered = 0;
  for (int radius : state.projected.radius) rendered += radius > 0;
  return rendered;
}

GaussianModel Gaussians(const std::vector<Eigen::Vector3f>& means,
                        const std::vector<Eigen::Vector3f>& log_scales,
                        const std::vector<Eigen::Vector4f>& quats,
                        float opacity_logit) {
  GaussianModel m;
  m.Resize(means.size());
  for (std::size_t i = 0; i < means.size(); ++i) {
    Eigen::Vector3f::Map(&m.means[i * 3]) = means[i];
    Eigen::Vector3f::Map(&m.log_scales[i * 3]) = log_scales[i];
    Eigen::Vector4f::Map(&m.quats[i * 4]) = quats[i];
    m.opacities[i] = opacity_logit;
    for (int c = 0; c < 3; ++c) m.sh[i * 3 + c] = 0.5f;
  }
  return m;
}

// Near-degenerate covariances: needles, flat discs, vanishing and huge
// scales, unnormalised quaternions, saturated opacities.
CaseResult DegenerateCovariances() {
  CaseResult c("degenerate covariances");
  const RasterCamera camera = BenchCamera(160, 120);
  std::vector<Eigen::Vector3f> means, scales;
  std::vector<Eigen::Vector4f> quats;
  const std::vector<Eigen::Vector3f> shapes = {
      {-20, -20, 0}, {0, 0, -25}, {-30, -30, -30}, {-1, -1, -1},
      {8, 8, 8},     {-25, 0, 0}, {-12, -12, -12}, {-2, -9, -16}};
  const std::vector<Eigen::Vector4f> rotations = {{1, 0, 0, 0},
                                                  {1e-6f, 0, 0, 1e-6f},
                                                  {1e6f, 1e6f, 0, 0},
                                                  {0.3f, 0.1f, -0.7f, 0.2f}};
  for (std::size_t i = 0; i < shapes.size(); ++i)
    for (std::size_t k = 0; k < rotations.size(); ++k) {
      means.emplace_back(0.2f * (static_cast<float>(i) - 3.5f),
                         0.2f * (static_cast<float>(k) - 1.5f), 3.0f);
      scales.push_back(shapes[i]);
      quats.push_back(rotations[k]);
    }
  for (float logit : {-30.0f, 0.0f, 30.0f}) {
    double alpha = 0;
    const int rendered = RenderBothWays(Gaussians(means, scales, quats, logit),
                                        camera, &c.count, &alpha);
    c.metrics["rendered_at_logit_" + std::to_string(static_cast<int>(logit))] =
        rendered;
    c.metrics["mean_alpha_at_logit_" +
              std::to_string(static_cast<int>(logit))] = alpha;
  }
  c.metrics["gaussians"] = means.size();
  return c;
}

// Very near and very far geometry: a Gaussian of 1% of its depth at depths
// from 1e-6 to 1e9.
CaseResult NearAndFar() {
  CaseResult c("very near and very far geometry");
  const RasterCamera camera = BenchCamera(160, 120);
  for (double z : {1e-6, 1e-3, 1e-2, 1.0, 1e3, 1e6, 1e9}) {
    const float s = std::log(static_cast<float>(0.01 * z));
    double alpha = 0;
    const int rendered = RenderBothWays(
        Gaussians(
            {{0.01f * static_cast<float>(z), 0.0f, static_cast<float>(z)}},
            {{s, s, s}}, {{1, 0, 0, 0}}, 2.0f),
        camera, &c.count, &alpha);
    char key[32];
    std::snprintf(key, sizeof(key), "rendered_at_%g", z);
    c.metrics[key] = rendered;
  }
  return c;
}

// The panorama's seam (phi = +-pi) and poles (theta = +-pi/2): directions
// there round-trip through Project and Direction, land on pixels inside
// the image, and splat without non-finite values.
CaseResult SeamAndPoles() {
  CaseResult c("panorama seam and poles");
  EquirectProjection p;
  p.width = 256;
  p.height = 128;
  p.center = {0.5, -1, 2};
  p.r_align = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())
                  .toRotationMatrix();
  double worst = 0;
  int outside = 0;
  std::vector<Eigen::Vector3f> points, colors;
  const double eps = 1e-12;
  for (double phi : {-M_PI, -M_PI + eps, -M_PI / 2, 0.0, M_PI - eps, M_PI}) {
    for (double theta :
         {-M_PI / 2, -M_PI / 2 + eps, 0.0, M_PI / 2 - eps, M_PI / 2}) {
      for (double distance : {1e-3, 1.0, 1e3}) {
        const Eigen::Vector3d local(std::cos(theta) * std::cos(phi),
                                    std::cos(theta) * std::sin(phi),
                                    std::sin(theta));
        const Eigen::Vector3d point = p.center + p.r_align * local * distance;
        const Eigen::Vector2d uv = p.Project(point);
        const Eigen::Vector3d back = p.Direction(uv);
        c.count.Add(uv.x());
        c.count.Add(uv.y());
        c.count.Add(back.x() + back.y() + back.z());
        worst = std::max(
            worst, std::acos(std::clamp(
                       back.dot((p.r_align * local).normalized()), -1.0, 1.0)));
        const Eigen::Vector2i px = p.Pixel(uv);
        outside +=
            px.x() < 0 || px.x() >= p.width || px.y() < 0 || px.y() >= p.height;
        points.push_back(point.cast<float>());
        colors.emplace_back(1, 0.5f, 0.25f);
      }
    }
  }
  const PanoramaImage image = SplatPoints(p, points, colors, 0.05);
  c.count.Add(image.rgb);
  c.count.Add(image.distance);
  c.metrics["max_round_trip_error_rad"] = worst;
  c.metrics["pixels_outside_image"] = outside;
  return c;
}

// Expansion angles up to 90 degrees: the expanded cameras of 8 directions
// at each angle, and a frame (a tilted plane with a box) warped into them.
CaseResult ExpansionAngles() {
  CaseResult c("expansion angles up to 90 degrees");
  const RasterCamera source = BenchCamera(160, 120);
  cv::Mat rgb(source.height, source.width, CV_32FC3);
  cv::Mat depth(source.height, source.width, CV_32FC1);
  cv::randu(rgb, 0.0, 1.0);
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x) {
      const bool box = std::abs(x - 80) < 20 && std::abs(y - 60) < 15;
      depth.at<float>(y, x) = box ? 2.0f : 4.0f + 0.01f * y;
    }
  const Eigen::Vector3d center(0, 0, 4);
  double drift = 0;  // over every angle
  for (double alpha : {15.0, 30.0, 45.0, 60.0, 75.0, 90.0}) {
    ExpansionGeometry g;
    g.steps = 1;
    g.alpha_degrees = alpha;
    const std::vector<ExpandedView> views =
        ExpansionViews(g, source, center, {source}, {0}, 1);
    double holes = 0;
    for (const ExpandedView& v : views) {
      c.count.Add(std::vector<float>(v.camera.rotation.data(),
                                     v.camera.rotation.data() + 9));
      c.count.Add(std::vector<float>(v.camera.translation.data(),
                                     v.camera.translation.data() + 3));
      drift = std::max(
          drift, std::abs((v.camera.Center().cast<double>() - center).norm() -
                          (source.Center().cast<double>() - center).norm()));
      const WarpResult w = ForwardWarp(rgb, depth, source, v.camera);
      c.count.Add(w.rgb);
      c.count.Add(w.depth);
      holes += static_cast<double>(cv::countNonZero(w.mask)) / w.mask.total();
    }
    char key[32];
    std::snprintf(key, sizeof(key), "holes_at_%g_deg", alpha);
    c.metrics[key] = holes / views.size();
    c.metrics["max_orbit_radius_drift"] = drift;
  }
  return c;
}

// A short fit on the tiny synthetic scene's views, transformed: the
// scene scaled by `scale` (camera translations and depth), or a static
// camera (validation camera 1's frames, which never move, as the video).
struct Scene {
  std::vector<TrainingView> train;
  std::vector<TrainingView> test;
  int num_times = 0;
};

Scene TinyScene(const fs::path& dir) {
  synth::SynthOptions s;
  s.preset = "tiny";
  synth::GenerateSynthScene(s, dir / "tiny");
  const Workspace ws(dir / "ws");
  DepthOptions d;
  d.dataset = dir / "tiny";
  RunDepth(ws, d);
  const WorkspaceFrames frames = ReadWorkspaceFrames(ws.root());
  Scene scene;
  scene.num_times = frames.num_times;
  scene.train = LoadTrainingViews(frames.train);
  std::vector<WorkspaceFrame> val = frames.val;
  for (WorkspaceFrame& f : val) {
    const fs::path depth = dir / "tiny" / "depth" / "2x" / (f.name + ".npy");
    if (fs::exists(depth)) f.depth = depth;
    const fs::path mask = dir / "tiny" / "dynamic" / "2x" / (f.name + ".png");
    if (fs::exists(mask)) f.dynamic_mask = mask;
  }
  scene.test = LoadTrainingViews(val);
  return scene;
}

ValidationView ToValidation(const TrainingView& v) {
  ValidationView out;
  out.name = v.name;
  out.time = v.time;
  out.camera = v.camera;
  out.rgb = Image::FromRgb32f(
      MatView(v.rgb, v.camera.height, v.camera.width, 3).clone());
  return out;
}

// The fit of `scene` as `pano4d fit --no-expansion` runs it on depth the
// dataset gives, in a workspace of its own under `dir`. A stage that meets
// a non-finite value throws; the case counts that as one.
CaseResult Fit(const std::string& name, const Scene& scene, int iterations,
               const fs::path& dir) {
  CaseResult c(name);
  FitInputs inputs;
  inputs.train = scene.train;
  for (const TrainingView& v : scene.test)
    inputs.val.push_back(ToValidation(v));
  inputs.num_times = scene.num_times;
  inputs.depth_source = kDepthFromDataset;
  FitOptions options;
  options.iterations = iterations;
  options.expand = false;
  options.validate_every = options.checkpoint_every = options.log_every =
      iterations;
  const Workspace ws(dir);
  try {
    const FitSummary s = FitController(ws, options, inputs).Run();
    const GaussianScene fitted = ReadCheckpointScene(ws.checkpoint());
    GaussianModel posed;
    for (int t = 0; t < scene.num_times; ++t) {
      fitted.ComposeAt(t, &posed);
      c.count.Add(posed);
    }
    c.count.Add(s.train_psnr);
    c.count.Add(s.last_validation.psnr.value_or(0.0));
    c.metrics["train_psnr"] = s.train_psnr;
    c.metrics["val_psnr"] = s.last_validation.psnr
                                ? nlohmann::json(*s.last_validation.psnr)
                                : nlohmann::json();
    c.metrics["gaussians"] = s.static_gaussians + s.dynamic_gaussians;
    c.metrics["skipped_steps"] = s.skipped_steps;
  } catch (const Error& e) {
    ++c.count.values;
    ++c.count.non_finite;
    c.metrics["error"] = e.what();
  }
  return c;
}

Scene Scaled(Scene s, float scale) {
  for (auto* views : {&s.train, &s.test})
    for (TrainingView& v : *views) {
      v.camera.translation *= scale;
      for (float& z : v.depth) z *= scale;
    }
  return s;
}

// Camera 1 of the validation split never moves: its frames (with their
// depth) are the video, and camera 2's frames are the test views.
Scene StaticCamera(Scene s) {
  std::vector<TrainingView> val = std::move(s.test);
  s.train.clear();
  s.test.clear();
  for (TrainingView& v : val) {
    const bool video = v.name.rfind("1_", 0) == 0 && !v.depth.empty();
    (video ? s.train : s.test).push_back(std::move(v));
  }
  return s;
}

}  // namespace

StabilityResult RunBenchStability(const StabilityOptions& o) {
  const fs::path dir = fs::temp_directory_path() /
                       ("pano4d_stability_" + std::to_string(::getpid()));
  EnsureDirectory(dir);
  std::vector<CaseResult> results;
  const auto run = [&](auto make) {
    const auto start = std::chrono::steady_clock::now();
    CaseResult r = make();
    r.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count();
    results.push_back(std::move(r));
  };
  run(ExpansionAngles);
  run(SeamAndPoles);
  run(DegenerateCovariances);
  run(NearAndFar);
  const Scene tiny = TinyScene(dir);
  const int n = o.fit_iterations;
  run([&] { return Fit("tiny scene, scale 1", tiny, n, dir / "fit_1"); });
  run([&] {
    return Fit("tiny scene scaled by 1e-3", Scaled(tiny, 1e-3f), n,
               dir / "fit_1e-3");
  });
  run([&] {
    return Fit("tiny scene scaled by 1e3", Scaled(tiny, 1e3f), n,
               dir / "fit_1e3");
  });
  run([&] {
    return Fit("static-camera video", StaticCamera(tiny), n,
               dir / "fit_static");
  });
  fs::remove_all(dir);

  StabilityResult result;
  char line[256];
  std::snprintf(line, sizeof(line), "%-36s %12s %10s %8s  %s\n", "case",
                "values", "non-finite", "seconds", "metrics");
  result.bench.table = line;
  for (const CaseResult& r : results) {
    result.non_finite += r.count.non_finite;
    result.bench.rows.push_back({{"case", r.name},
                                 {"values", r.count.values},
                                 {"non_finite", r.count.non_finite},
                                 {"seconds", r.seconds},
                                 {"metrics", r.metrics}});
    std::snprintf(line, sizeof(line), "%-36s %12lld %10lld %8.2f  ",
                  r.name.c_str(), static_cast<long long>(r.count.values),
                  static_cast<long long>(r.count.non_finite), r.seconds);
    result.bench.table += line + r.metrics.dump() + "\n";
  }
  return result;
}

}  // namespace pano4d
