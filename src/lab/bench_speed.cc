// `pano4d bench camera` and `bench render`: speed tables (bench.h).
#include <algorithm>
#include <cstdio>
#include <random>

#include <omp.h>

#include "src/core/camera.h"
#include "src/core/camera_check.h"
#include "src/core/error.h"
#include "src/core/frames.h"
#include "src/core/median.h"
#include "src/core/strings.h"
#include "src/core/timer.h"
#include "src/core/version.h"
#include "src/core/workspace.h"
#include "src/gs/trainer.h"
#include "src/lab/bench.h"
#include "src/pipeline/fit_options.h"
#include "src/render/bench_scene.h"
#include "src/render/rasterize_to_pixels.h"
#include "src/render/rasterizer.h"

namespace pano4d {
namespace {

struct CameraCase {
  std::string label;
  Camera camera;
};

// 640x480 cameras with strong distortion where the model has any. The
// barrel cases keep the image corners inside the region where the model is
// one-to-one (see the camera tests for cases beyond it).
std::vector<CameraCase> BenchCameras() {
  constexpr int kW = 640;
  constexpr int kH = 480;
  const auto make = [](CameraModelId id, std::vector<double> params) {
    return Camera{id, kW, kH, std::move(params)};
  };
  return {
      {"none", make(CameraModelId::kSimplePinhole, {500, 320, 240})},
      {"none", make(CameraModelId::kPinhole, {500, 505, 320, 240})},
      {"k=-0.4", make(CameraModelId::kSimpleRadial, {800, 320, 240, -0.4})},
      {"k=+0.4", make(CameraModelId::kSimpleRadial, {500, 320, 240, 0.4})},
      {"k1=-0.4 k2=0.1",
       make(CameraModelId::kRadial, {800, 320, 240, -0.4, 0.1})},
      {"k1=-0.4 p=1e-3", make(CameraModelId::kOpenCV,
                              {800, 805, 320, 240, -0.4, 0.1, 1e-3, -1e-3})},
      {"80 deg at corner",
       make(CameraModelId::kOpenCVFisheye,
            {268, 268, 320, 240, 0.05, -0.01, 0.002, -0.0005})},
      {"rational",
       make(CameraModelId::kFullOpenCV, {600, 600, 320, 240, -0.3, 0.08, 1e-3,
                                         -1e-3, -0.01, 0.05, 0.01, 0.001})},
      {"omega=0.9", make(CameraModelId::kFOV, {400, 400, 320, 240, 0.9})},
      {"k=0.05",
       make(CameraModelId::kSimpleRadialFisheye, {280, 320, 240, 0.05})},
      {"k1=0.05 k2=-0.01",
       make(CameraModelId::kRadialFisheye, {280, 320, 240, 0.05, -0.01})},
      {"thin prism", make(CameraModelId::kThinPrismFisheye,
                          {280, 280, 320, 240, 0.05, -0.01, 1e-3, -1e-3, 0.002,
                           -0.0005, 1e-3, -1e-3})},
  };
}

// Runs `body` in growing batches until min_seconds have passed; returns
// nanoseconds per call of `calls_per_body` calls.
template <typename F>
double NanosecondsPerCall(double min_seconds, std::int64_t calls_per_body,
                          F&& body) {
  std::int64_t repeats = 1;
  while (true) {
    Timer timer;
    for (std::int64_t r = 0; r < repeats; ++r) body();
    const double seconds = timer.WallSeconds();
    if (seconds >= min_seconds)
      return 1e9 * seconds / (repeats * calls_per_body);
    repeats *= 2;
  }
}

// The trainer phases that a step takes on every step, seconds.
double StepSeconds(const PhaseTimes& t) {
  return t.compose + t.forward + t.loss + t.backward + t.motion + t.optimise;
}

// Mean phase times of `steps` fit steps on `scene` and the workspace's
// training frames, with the options a default fit of them resolves to
// (losses, appearance) and densification off, after one warm-up step:
// what a step costs beside the rasterizer.
PhaseTimes FitStepPhases(const GaussianScene& scene,
                         const WorkspaceFrames& frames, int steps) {
  FitOptions given;
  given.iterations = steps + 1;
  const FitOptions used = ResolveFitOptions(given, FitInputOf(frames));
  TrainerOptions options = used.trainer;
  options.strategy.densify_from = options.strategy.densify_until =
      options.iterations + 1;
  Trainer trainer(scene, LoadTrainingViews(frames.train), options, 0);
  trainer.Step();
  const PhaseTimes warm = trainer.times();
  for (int i = 0; i < steps; ++i) trainer.Step();
  PhaseTimes t = trainer.times();
  for (auto [total, first] : {std::pair{&t.compose, warm.compose},
                              {&t.forward, warm.forward},
                              {&t.loss, warm.loss},
                              {&t.backward, warm.backward},
                              {&t.motion, warm.motion},
                              {&t.optimise, warm.optimise}})
    *total = (*total - first) / steps;
  return t;
}

// Seconds each blend probe runs (ProbeBlendCeiling): long enough that a
// scheduler's tick does not decide it.
constexpr double kProbeSeconds = 0.5;

// Medians over runs of rendering a scene, forward and backward, with the
// rasterizer's phases and per-run means of its counts.
struct RenderTimes {
  double compose = 0, forward = 0, backward = 0;
  double project = 0, bin = 0, blend = 0, blend_backward = 0,
         project_backward = 0;
  std::uint64_t visible = 0, evaluations = 0, entries = 0;  // summed
  std::uint64_t backward_evaluations = 0;                   // summed
  // (Gaussian, pixel) pairs per second of the blend, forward and backward:
  // summed pairs over summed blend time.
  double forward_pairs_per_s = 0, backward_pairs_per_s = 0;
};

// `repeats` runs, run r at camera r mod cameras and its time.
RenderTimes TimeRenders(const GaussianScene& scene,
                        const std::vector<RasterCamera>& cameras,
                        const std::vector<int>& times, int repeats) {
  GaussianModel model;
  Rasterizer rasterizer;
  RasterState state;
  RenderOutput out;
  scene.ComposeAt(times[0], &model);
  rasterizer.Forward(model, cameras[0], {}, &out, &state);  // warm-up
  std::vector<double> compose_ms, forward_ms, backward_ms, project_ms, bin_ms,
      blend_ms, blend_backward_ms, project_backward_ms;
  RenderTimes t;
  double blend_total = 0, blend_backward_total = 0;  // ms
  GaussianGradients grad;
  RenderGradients d_out;
  for (int r = 0; r < repeats; ++r) {
    const std::size_t v = static_cast<std::size_t>(r) % cameras.size();
    Timer compose;
    scene.ComposeAt(times[v], &model);
    compose_ms.push_back(1e3 * compose.WallSeconds());
    Timer forward;
    rasterizer.Forward(model, cameras[v], {}, &out, &state);
    forward_ms.push_back(1e3 * forward.WallSeconds());
    project_ms.push_back(state.stats.project_ms);
    bin_ms.push_back(state.stats.bin_ms);
    blend_ms.push_back(state.stats.blend_ms);
    t.visible += state.stats.visible;
    t.evaluations += state.stats.pixel_evaluations;
    t.entries += state.stats.tile_entries;
    d_out.rgb.assign(out.rgb.size(), 1e-3f);
    Timer backward;
    const RasterBackwardStats backward_stats =
        rasterizer.Backward(model, cameras[v], {}, state, out, d_out, &grad);
    backward_ms.push_back(1e3 * backward.WallSeconds());
    blend_backward_ms.push_back(backward_stats.blend_ms);
    t.backward_evaluations += backward_stats.pixel_evaluations;
    blend_total += state.stats.blend_ms;
    blend_backward_total += backward_stats.blend_ms;
    project_backward_ms.push_back(backward_stats.project_ms);
  }
  t.compose = UpperMedian(compose_ms);
  t.forward = UpperMedian(forward_ms);
  t.backward = UpperMedian(backward_ms);
  t.project = UpperMedian(project_ms);
  t.bin = UpperMedian(bin_ms);
  t.blend = UpperMedian(blend_ms);
  t.blend_backward = UpperMedian(blend_backward_ms);
  t.project_backward = UpperMedian(project_backward_ms);
  t.forward_pairs_per_s = t.evaluations / (1e-3 * blend_total);
  t.backward_pairs_per_s =
      t.backward_evaluations / (1e-3 * blend_backward_total);
  return t;
}

// The fitted scene of a workspace (`pano4d fit`'s checkpoint) rendered
// from its training cameras at their times, one camera per run, cycling.
BenchResult BenchFittedScene(const BenchRenderOptions& options) {
  const int threads = omp_get_max_threads();
  const Workspace ws(options.workspace);
  const GaussianScene scene = ReadCheckpointScene(ws.checkpoint());
  const WorkspaceFrames frames = ReadWorkspaceFrames(ws.root());
  std::vector<RasterCamera> cameras;
  std::vector<int> times;
  for (const WorkspaceFrame& f : frames.train) {
    cameras.push_back(RasterCamera::FromPosed(f.camera));
    times.push_back(f.time);
  }
  const int repeats = options.repeats;
  const RenderTimes t = TimeRenders(scene, cameras, times, repeats);
  const double f = t.forward, b = t.backward, c = t.compose;
  const PhaseTimes step = FitStepPhases(scene, frames, repeats);
  // The blend's ceiling on one and two threads, and at this bench's count.
  const BlendCeiling one = ProbeBlendCeiling(1, kProbeSeconds);
  const BlendCeiling two = ProbeBlendCeiling(2, kProbeSeconds);
  const BlendCeiling here =
      threads == 1
          ? one
          : (threads == 2 ? two : ProbeBlendCeiling(threads, kProbeSeconds));
  const double forward_share = t.forward_pairs_per_s / here.forward_pairs_per_s;
  const double backward_share =
      t.backward_pairs_per_s / here.backward_pairs_per_s;
  const auto probe_json = [](const BlendCeiling& c) {
    return nlohmann::json{{"forward_pairs_per_s", c.forward_pairs_per_s},
                          {"backward_pairs_per_s", c.backward_pairs_per_s}};
  };
  const int width = cameras[0].width, height = cameras[0].height;
  BenchResult result;
  result.rows.push_back(
      {{"workspace", ws.root().string()},
       {"gaussians", scene.size()},
       {"static", scene.statics.size()},
       {"dynamic", scene.dynamics.size()},
       {"width", width},
       {"height", height},
       {"threads", threads},
       {"compose_ms", c},
       {"forward_ms", f},
       {"project_ms", t.project},
       {"bin_ms", t.bin},
       {"blend_ms", t.blend},
       {"blend_backward_ms", t.blend_backward},
       {"project_backward_ms", t.project_backward},
       {"forward_backward_ms", f + b},
       {"fps", 1e3 / f},
       {"visible", t.visible / repeats},
       {"tile_entries", t.entries / repeats},
       {"pixel_evaluations", t.evaluations / repeats},
       {"pixel_evaluations_per_s", t.evaluations / (1e-3 * f * repeats)},
       {"blend",
        {{"forward_pairs_per_s", t.forward_pairs_per_s},
         {"backward_pairs_per_s", t.backward_pairs_per_s},
         {"backward_pairs", t.backward_evaluations / repeats},
         {"ceiling", probe_json(here)},
         {"ceiling_1_thread", probe_json(one)},
         {"ceiling_2_threads", probe_json(two)},
         {"forward_fraction", forward_share},
         {"backward_fraction", backward_share}}},
       {"step_ms",
        {{"compose", 1e3 * step.compose},
         {"forward", 1e3 * step.forward},
         {"loss", 1e3 * step.loss},
         {"backward", 1e3 * step.backward},
         {"motion", 1e3 * step.motion},
         {"optimise", 1e3 * step.optimise},
         {"total", 1e3 * StepSeconds(step)}}}});
  result.table = StringPrintf(
      "pano4d %s bench render: the fitted scene of %s (%zu static, %zu "
      "dynamic Gaussians) from its %zu training cameras at their times; "
      "median of %d runs, %d threads\n",
      kVersion, ws.root().c_str(), scene.statics.size(), scene.dynamics.size(),
      cameras.size(), repeats, threads);
  result.table +=
      StringPrintf("%10s %10s %11s %12s %8s %18s %14s\n", "gaussians", "size",
                   "compose ms", "forward ms", "fps", "fwd+bwd ms", "visible");
  result.table +=
      StringPrintf("%10zu %6dx%-4d %11.2f %12.2f %8.1f %18.2f %14llu\n",
                   scene.size(), width, height, c, f, 1e3 / f, f + b,
                   static_cast<unsigned long long>(t.visible / repeats));
  result.table += StringPrintf(
      "forward: project %.2f, bin %.2f, blend %.2f ms; backward: blend "
      "%.2f, project %.2f ms (medians)\n",
      t.project, t.bin, t.blend, t.blend_backward, t.project_backward);
  result.table += StringPrintf(
      "blend: forward %.1f M pairs/s, %.0f%% of the probed ceiling (%.1f M "
      "at %d threads); backward %.1f M pairs/s, %.0f%% of %.1f M (probe, 1 "
      "thread: %.1f / %.1f M, 2 threads: %.1f / %.1f M)\n",
      1e-6 * t.forward_pairs_per_s, 100 * forward_share,
      1e-6 * here.forward_pairs_per_s, threads, 1e-6 * t.backward_pairs_per_s,
      100 * backward_share, 1e-6 * here.backward_pairs_per_s,
      1e-6 * one.forward_pairs_per_s, 1e-6 * one.backward_pairs_per_s,
      1e-6 * two.forward_pairs_per_s, 1e-6 * two.backward_pairs_per_s);
  result.table += StringPrintf(
      "fit step (densification off, mean of %d): %.2f ms: compose %.2f, "
      "forward %.2f, losses %.2f, backward %.2f, motion %.2f, optimiser "
      "%.2f ms\n",
      repeats, 1e3 * StepSeconds(step), 1e3 * step.compose, 1e3 * step.forward,
      1e3 * step.loss, 1e3 * step.backward, 1e3 * step.motion,
      1e3 * step.optimise);
  return result;
}

}  // namespace

BenchResult RunBenchCamera(const BenchCameraOptions& options) {
  const int grid_x = options.grid;
  const int grid_y = options.grid * 3 / 4;
  BenchResult result;
  result.table = StringPrintf(
      "pano4d %s bench camera: 640x480, %d pixels per model (edge to edge, "
      "corners included), 1 thread\n",
      kVersion, (grid_x + 1) * (grid_y + 1));
  result.table += StringPrintf("%-22s %-18s %13s %6s %6s %11s %13s\n", "model",
                               "distortion", "max err (px)", "fail", "iters",
                               "project ns", "unproject ns");
  for (const CameraCase& c : BenchCameras()) {
    const Camera& camera = c.camera;
    camera.Check(c.label);
    const RoundTripStats stats = MeasureRoundTrip(camera, grid_x, grid_y);
    std::vector<Eigen::Vector2d> pixels;
    std::vector<Eigen::Vector3d> rays;
    for (int j = 0; j <= grid_y; ++j) {
      for (int i = 0; i <= grid_x; ++i) {
        const Eigen::Vector2d pixel(camera.width * double(i) / grid_x,
                                    camera.height * double(j) / grid_y);
        const UnprojectResult r = camera.Unproject(pixel);
        if (!r.ok()) continue;
        pixels.push_back(pixel);
        rays.push_back(r.ray);
      }
    }
    double sink = 0.0;
    const std::int64_t n = static_cast<std::int64_t>(pixels.size());
    const double project_ns = NanosecondsPerCall(options.min_seconds, n, [&] {
      for (const Eigen::Vector3d& ray : rays)
        sink += camera.Project(ray).value_or(Eigen::Vector2d::Zero()).x();
    });
    const double unproject_ns = NanosecondsPerCall(options.min_seconds, n, [&] {
      for (const Eigen::Vector2d& pixel : pixels)
        sink += camera.Unproject(pixel).ray.x();
    });
    // An empty asm that reads `sink` keeps the compiler from dropping the
    // timed calls (what benchmark::DoNotOptimize does).
    asm volatile("" : : "r,m"(sink) : "memory");
    const std::string model(camera.info().name);
    result.rows.push_back({{"model", model},
                           {"distortion", c.label},
                           {"samples", stats.samples},
                           {"failures", stats.failures},
                           {"max_error_px", stats.max_error_px},
                           {"mean_iterations", stats.mean_iterations},
                           {"project_ns", project_ns},
                           {"unproject_ns", unproject_ns}});
    result.table +=
        StringPrintf("%-22s %-18s %13.2e %6lld %6.1f %11.1f %13.1f\n",
                     model.c_str(), c.label.c_str(), stats.max_error_px,
                     static_cast<long long>(stats.failures),
                     stats.mean_iterations, project_ns, unproject_ns);
  }
  return result;
}

BenchResult RunBenchRender(const BenchRenderOptions& options) {
  if (!options.workspace.empty()) return BenchFittedScene(options);
  const int threads = omp_get_max_threads();
  BenchResult result;
  result.table = StringPrintf(
      "pano4d %s bench render: random view-filling scene, mean 3-sigma "
      "radius 4 px, opacity 0.5; median of %d runs, %d threads\n",
      kVersion, options.repeats, threads);
  result.table +=
      StringPrintf("%10s %10s %12s %8s %18s %14s %16s\n", "gaussians", "size",
                   "forward ms", "fps", "fwd+bwd ms", "visible", "evals/s");
  for (const std::string& size : options.sizes) {
    int width = 0, height = 0;
    if (std::sscanf(size.c_str(), "%dx%d", &width, &height) != 2 ||
        width <= 0 || height <= 0) {
      throw Error("--size", "", size, "expected WxH, e.g. 480x360");
    }
    const RasterCamera camera = BenchCamera(width, height);
    for (const int n : options.gaussians) {
      const GaussianModel model =
          RandomViewFillingScene(static_cast<std::size_t>(n), camera, 4.0f, 1);
      Rasterizer rasterizer;
      RasterState state;
      RenderOutput out;
      // Warm-up: buffers reach their size.
      rasterizer.Forward(model, camera, {}, &out, &state);
      std::vector<double> ms;
      for (int r = 0; r < options.repeats; ++r) {
        Timer timer;
        rasterizer.Forward(model, camera, {}, &out, &state);
        ms.push_back(1e3 * timer.WallSeconds());
      }
      const double forward_ms = UpperMedian(ms);
      const RasterStats stats = state.stats;
      // Forward + backward with a fixed gradient on every output, as a
      // photometric loss would give.
      RenderGradients d_out;
      d_out.rgb.assign(out.rgb.size(), 1e-3f);
      GaussianGradients grad;
      std::vector<double> ms_fb;
      for (int r = 0; r < options.repeats; ++r) {
        Timer timer;
        rasterizer.Forward(model, camera, {}, &out, &state);
        rasterizer.Backward(model, camera, {}, state, out, d_out, &grad);
        ms_fb.push_back(1e3 * timer.WallSeconds());
      }
      const double forward_backward_ms = UpperMedian(ms_fb);
      const double evals_per_s = stats.pixel_evaluations / (forward_ms * 1e-3);
      result.rows.push_back({{"gaussians", n},
                             {"width", width},
                             {"height", height},
                             {"threads", threads},
                             {"forward_ms", forward_ms},
                             {"forward_backward_ms", forward_backward_ms},
                             {"fps", 1e3 / forward_ms},
                             {"visible", stats.visible},
                             {"pixel_evaluations_per_s", evals_per_s}});
      result.table += StringPrintf(
          "%10d %10s %12.2f %8.1f %18.2f %14llu %16.3g\n", n, size.c_str(),
          forward_ms, 1e3 / forward_ms, forward_backward_ms,
          static_cast<unsigned long long>(stats.visible), evals_per_s);
    }
  }
  return result;
}

}  // namespace pano4d
