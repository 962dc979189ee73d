#include "src/datasets/synth_generate.h"

#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/npy.h"
#include "src/core/progress.h"
#include "src/core/timer.h"
#include "src/datasets/dycheck_dataset.h"
#include "src/datasets/synth_cameras.h"
#include "src/datasets/synth_priors.h"
#include "src/datasets/synth_render.h"

namespace pano4d::synth {
namespace fs = std::filesystem;
namespace {

constexpr double kFps = 30.0;
// A 58-degree horizontal field of view, like a phone's main camera.
constexpr double kFocalPerWidth = 0.9;

void WriteDepth(const fs::path& path, const cv::Mat& depth) {
  std::vector<float> values(depth.begin<float>(), depth.end<float>());
  WriteNpy(path, NpyArray::FromFloats({depth.rows, depth.cols, 1}, values));
}

// Writes one frame's ground truth at 1x and 2x; returns the 2x render.
RenderedFrame WriteFrame(const Scene& scene, const PosedCamera& camera_1x,
                         double s, const std::string& id, const fs::path& out,
                         bool keep_surface_2x, cv::Mat* depth_1x,
                         double* render_seconds, double* write_seconds) {
  Timer render_timer;
  const RenderedFrame full =
      RenderFrame(scene, camera_1x, s, /*shade=*/true, false);
  PosedCamera camera_2x = camera_1x;
  camera_2x.camera = camera_1x.camera.Rescaled(camera_1x.camera.width / 2,
                                               camera_1x.camera.height / 2);
  RenderedFrame half =
      RenderFrame(scene, camera_2x, s, /*shade=*/false, keep_surface_2x);
  // DyCheck's 2x images are its 1x images resized; an exact halving is the
  // mean of each 2x2 block.
  cv::Mat rgb_2x;
  cv::resize(full.rgb.mat(), rgb_2x, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  half.rgb = Image::FromRgb32f(rgb_2x);
  *render_seconds += render_timer.WallSeconds();

  Timer write_timer;
  const std::string png = id + ".png";
  WriteImage(out / "rgb" / "1x" / png, full.rgb);
  WriteImage(out / "rgb" / "2x" / png, half.rgb);
  WriteDepth(out / "depth" / "1x" / (id + ".npy"), full.depth);
  WriteDepth(out / "depth" / "2x" / (id + ".npy"), half.depth);
  WriteMask(out / "instance" / "1x" / png, full.instance);
  WriteMask(out / "instance" / "2x" / png, half.instance);
  WriteMask(out / "dynamic" / "1x" / png, full.dynamic);
  WriteMask(out / "dynamic" / "2x" / png, half.dynamic);
  *write_seconds += write_timer.WallSeconds();
  if (depth_1x) *depth_1x = full.depth;
  return half;
}

double TimeOf(int t, int frames) {
  return frames > 1 ? static_cast<double>(t) / (frames - 1) : 0.0;
}

}  // namespace

const std::vector<Preset>& Presets() {
  static const std::vector<Preset> presets = {
      {"tiny", 128, 96, 8, 8},
      {"small", 480, 360, 48, 48},
      {"medium", 960, 720, 120, 120},
  };
  return presets;
}

const Preset& GetPreset(const std::string& name) {
  for (const Preset& p : Presets()) {
    if (p.name == name) return p;
  }
  throw Error("synth", "preset", "\"" + name + "\"",
              "unknown preset; use tiny, small or medium");
}

Json SynthSummary::ToJson() const {
  Json j{{"generator", "pano4d synth"},
         {"preset", preset.name},
         {"width", preset.width},
         {"height", preset.height},
         {"train_frames", preset.train_frames},
         {"val_frames_per_camera", preset.val_frames},
         {"seed", seed},
         {"static", is_static},
         {"covisibility",
          {{"resolution", "2x"},
           {"rule",
            "covisible when seen unoccluded in more than threshold "
            "training views"},
           {"threshold", covisibility_threshold},
           {"val_pixels", val_pixels},
           {"unseen_pixels", unseen_pixels},
           {"unseen_fraction", unseen_fraction}}}};
  // Only when set, so that default scenes keep their bytes.
  if (dynamic_scale != 1.0) j["dynamic_scale"] = dynamic_scale;
  if (trajectory != TrainingMotion::kArc)
    j["trajectory"] = TrainingMotionName(trajectory);
  if (varied) {
    j["varied"] = true;
    j["layout"] = layout;
  }
  if (priors) j["priors"] = PriorErrorModel().ToJson();
  return j;
}

namespace {

// DyCheck's scene.json values for the synthetic room (its near and far are
// set from the training depth).
DyCheckScene DyCheckSceneOf(const Scene& scene) {
  DyCheckScene dycheck;
  dycheck.fps = kFps;
  dycheck.center = scene.target;
  dycheck.scale = 1.0 / ((scene.room_max - scene.room_min).norm());
  dycheck.lookat = Eigen::Vector3d::Zero();  // the target, in normalised units
  dycheck.up = Eigen::Vector3d::UnitZ();
  dycheck.bbox_min = (scene.room_min - scene.target) * dycheck.scale;
  dycheck.bbox_max = (scene.room_max - scene.target) * dycheck.scale;
  return dycheck;
}

// The training video (camera 0): its frames and depth, which the
// validation frames' covisibility is counted against.
std::vector<TrainingView> WriteTrainingFrames(
    const Scene& scene, const std::vector<PosedCamera>& cameras,
    const fs::path& out, DyCheckScene* dycheck, SynthSummary* summary,
    ProgressBar* progress) {
  const int train_frames = static_cast<int>(cameras.size());
  std::vector<TrainingView> views;
  double near = std::numeric_limits<double>::infinity(), far = 0;
  for (int t = 0; t < train_frames; ++t) {
    const double s = TimeOf(t, train_frames);
    TrainingView view{cameras[t], PosesAt(scene, s), {}};
    WriteFrame(scene, cameras[t], s, DyCheckFrameId(0, t), out, false,
               &view.depth, &summary->render_seconds, &summary->write_seconds);
    double lo = 0, hi = 0;
    cv::minMaxLoc(view.depth, &lo, &hi, nullptr, nullptr, view.depth > 0);
    near = std::min(near, lo);
    far = std::max(far, hi);
    views.push_back(std::move(view));
    dycheck->train.push_back({0, t, cameras[t]});
    progress->Add();
  }
  dycheck->near = 0.9 * near;
  dycheck->far = 1.1 * far;
  return views;
}

// The validation cameras 1 and 2 over the training video's clock, each
// frame with its covisible mask; the unseen share in `summary`.
void WriteValidationFrames(const Scene& scene, const Camera& intrinsics,
                           int val_frames,
                           const std::vector<TrainingView>& views,
                           const fs::path& out, DyCheckScene* dycheck,
                           SynthSummary* summary, ProgressBar* progress) {
  const int train_frames = static_cast<int>(views.size());
  for (int camera_id : {1, 2}) {
    const PosedCamera camera = ValidationCamera(scene, intrinsics, camera_id);
    for (int t = 0; t < val_frames; ++t) {
      const double s = TimeOf(t, train_frames);  // the training video's clock
      const std::string id = DyCheckFrameId(camera_id, t);
      const RenderedFrame half =
          WriteFrame(scene, camera, s, id, out, true, nullptr,
                     &summary->render_seconds, &summary->write_seconds);
      Timer covisibility_timer;
      const cv::Mat counts =
          CovisibleCounts(half, views, summary->covisibility_threshold + 1);
      const cv::Mat mask = CovisibleMask(counts, train_frames);
      const cv::Mat surface = half.depth > 0;
      summary->val_pixels += cv::countNonZero(surface);
      summary->unseen_pixels += cv::countNonZero(surface & ~mask);
      summary->covisibility_seconds += covisibility_timer.WallSeconds();
      WriteMask(out / "covisible" / "2x" / "val" / (id + ".png"), mask);
      dycheck->val.push_back({camera_id, t, camera});
      progress->Add();
    }
  }
  summary->unseen_fraction =
      summary->val_pixels > 0
          ? static_cast<double>(summary->unseen_pixels) / summary->val_pixels
          : 0;
}

}  // namespace

SynthSummary GenerateSynthScene(const SynthOptions& options,
                                const fs::path& out) {
  const Preset& preset = GetPreset(options.preset);
  if (!(options.dynamic_scale > 0 && options.dynamic_scale <= 10)) {
    throw Error("synth", "dynamic_scale", std::to_string(options.dynamic_scale),
                "must be in (0, 10]");
  }
  SynthSummary summary;
  summary.preset = preset;
  summary.seed = options.seed;
  summary.is_static = options.is_static;
  summary.dynamic_scale = options.dynamic_scale;
  summary.varied = options.varied;
  summary.trajectory = options.trajectory;
  summary.priors = options.priors;
  EnsureDirectory(out);
  // A rerun replaces everything, so a stale marker must not survive a kill.
  fs::remove(out / "synth.json");

  const Scene scene =
      BuildScene(options.seed, options.is_static, options.dynamic_scale,
                 options.varied ? VariedLayout(options.seed) : Layout());
  if (options.varied) summary.layout = scene.layout.ToJson();
  const double f = kFocalPerWidth * preset.width;
  const Camera intrinsics{CameraModelId::kPinhole,
                          preset.width,
                          preset.height,
                          {f, f, preset.width / 2.0, preset.height / 2.0}};
  const int train_frames = preset.train_frames;
  DyCheckScene dycheck = DyCheckSceneOf(scene);
  ProgressBar progress("synth " + preset.name,
                       train_frames + 2 * preset.val_frames);
  const std::vector<PosedCamera> train_cameras = TrainingTrajectory(
      scene, intrinsics, train_frames, options.seed, options.trajectory);
  const std::vector<TrainingView> views = WriteTrainingFrames(
      scene, train_cameras, out, &dycheck, &summary, &progress);
  summary.covisibility_threshold = CovisibilityThreshold(train_frames);
  WriteValidationFrames(scene, intrinsics, preset.val_frames, views, out,
                        &dycheck, &summary, &progress);
  progress.Finish();

  if (options.priors) {
    Timer priors_timer;
    std::vector<PriorFrameSource> sources;
    for (int t = 0; t < train_frames; ++t)
      sources.push_back(
          {train_cameras[t], TimeOf(t, train_frames), DyCheckFrameId(0, t)});
    WriteSynthPriors(scene, sources, options.seed, PriorErrorModel(), out);
    summary.write_seconds += priors_timer.WallSeconds();
  }
  WriteDyCheckMetadata(out, dycheck);
  WriteJson(out / "synth.json", summary.ToJson());
  return summary;
}

bool EnsureSynthScene(const SynthOptions& o, const fs::path& out) {
  const fs::path json = out / "synth.json";
  if (!fs::exists(json)) {
    GenerateSynthScene(o, out);
    return true;
  }
  const Json j = ReadJson(json);
  const std::string preset = GetJson<std::string>(j, "preset", json.string());
  const int seed = GetJson<int>(j, "seed", json.string());
  const bool is_static = GetJsonOr<bool>(j, "static", false, json.string());
  const bool varied = GetJsonOr<bool>(j, "varied", false, json.string());
  const std::string trajectory =
      GetJsonOr<std::string>(j, "trajectory", "arc", json.string());
  if (preset != o.preset || seed != static_cast<int>(o.seed) ||
      is_static != o.is_static || varied != o.varied ||
      trajectory != TrainingMotionName(o.trajectory)) {
    throw Error(
        json.string(), "preset/seed",
        preset + " seed " + std::to_string(seed) + (varied ? " varied" : ""),
        "an earlier run made another scene here; use another "
        "--workspace or remove " +
            out.string());
  }
  return false;
}

}  // namespace pano4d::synth
