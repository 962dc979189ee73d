// pano4d render: novel-view videos of the fitted scene (orbit, spiral,
// bullet time, or a camera file); pano4d export: 3DGS PLY per time step and
// the cameras as a COLMAP model.
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "src/cli/app.h"
#include "src/cli/expansion_outputs.h"
#include "src/cli/scene_outputs.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/progress.h"
#include "src/render/ply.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

// Default arcs: a full orbit, a 10-degree circle (a gentle "spiral" around
// the input view, which stays where the capture has content), a 60-degree
// bullet-time swing.
constexpr double kOrbitDegrees = 360.0;
constexpr double kSpiralDegrees = 10.0;
constexpr double kBulletDegrees = 60.0;

struct RenderCommandOptions {
  fs::path workspace;
  std::string trajectory = "orbit";
  int time = -1;  // bullet time; -1: the middle
  int frames = 60;
  double degrees = 0;  // 0: the path's default
  double fps = 10.0;
  fs::path out;  // default WS/pano4d/renders/<trajectory>
};

int RunRender(const RenderCommandOptions& o) {
  const FittedWorkspace fitted = LoadFittedWorkspace(o.workspace);
  const int num_times = fitted.scene.num_times;
  std::vector<TimedCamera> cameras;
  // Each camera as cameras.json will hold it; the cameras render from
  // these, so that the file renders the same frames again.
  std::vector<nlohmann::json> cameras_json;
  std::string name = o.trajectory;
  if (o.trajectory == "orbit" || o.trajectory == "spiral" ||
      o.trajectory == "bullet") {
    VideoPathOptions v;
    v.path = o.trajectory == "orbit"    ? VideoPath::kOrbit
             : o.trajectory == "spiral" ? VideoPath::kSpiral
                                        : VideoPath::kBullet;
    v.degrees = o.degrees > 0                  ? o.degrees
                : v.path == VideoPath::kOrbit  ? kOrbitDegrees
                : v.path == VideoPath::kSpiral ? kSpiralDegrees
                                               : kBulletDegrees;
    v.frames = o.frames;
    v.num_times = num_times;
    v.time = o.time >= 0 ? o.time : num_times / 2;
    if (v.time >= num_times) {
      throw Error(
          "--time", "", std::to_string(o.time),
          "must be below the scene's " + std::to_string(num_times) + " times");
    }
    const WorkspaceFrame& reference = fitted.MiddleFrame();
    cameras = VideoCameras(v, RasterCamera::FromPosed(reference.camera),
                           fitted.Center());
    for (TimedCamera& c : cameras) {
      cameras_json.push_back(CameraToJson(c.camera));
      c.camera = RasterCameraFromJson(cameras_json.back(), "render");
    }
  } else {
    if (!fs::exists(o.trajectory)) {
      throw Error("--trajectory", "", o.trajectory,
                  "is neither orbit, spiral, bullet nor an existing camera "
                  "file ({\"views\": [{\"camera\": {...}, \"t\": T}]})");
    }
    cameras = ReadCameraFile(o.trajectory, &cameras_json);
    name = fs::path(o.trajectory).stem().string();
    for (std::size_t i = 0; i < cameras.size(); ++i) {
      if (o.time >= 0) cameras[i].time = o.time;
      if (cameras[i].time < 0 || cameras[i].time >= num_times) {
        throw Error(o.trajectory + " view " + std::to_string(i), "t",
                    std::to_string(cameras[i].time),
                    "must be in [0, " + std::to_string(num_times) + ")");
      }
    }
  }
  const fs::path out =
      o.out.empty() ? o.workspace / "pano4d" / "renders" / name : o.out;
  EnsureDirectory(out);
  SceneRenderer renderer(fitted.scene);
  ProgressBar bar("render " + name, static_cast<std::int64_t>(cameras.size()));
  std::vector<cv::Mat> frames;
  nlohmann::json views = nlohmann::json::array();
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    frames.push_back(renderer.Render(cameras[i].camera, cameras[i].time));
    WriteImage(out / (Padded(static_cast<int>(i), 5) + ".png"),
               Image::FromOpenCV(frames.back(), name));
    views.push_back({{"camera", cameras_json[i]}, {"t", cameras[i].time}});
    bar.Add();
  }
  bar.Finish();
  // The cameras in the camera-file layout, so that the path can be edited
  // and rendered again with --trajectory FILE.
  WriteJson(out / "cameras.json", {{"views", views}});
  std::vector<std::string> notes;
  const fs::path video = out / (name + ".mp4");
  const bool wrote = WriteVideo(video, frames, o.fps, &notes);
  std::printf("pano4d render: %zu frames of %s in %s%s\n", frames.size(),
              name.c_str(), out.c_str(),
              wrote ? (", video " + video.string()).c_str() : "");
  for (const std::string& n : notes)
    std::printf("  not written: %s\n", n.c_str());
  return kExitOk;
}

struct ExportCommandOptions {
  fs::path workspace;
  fs::path out;  // default WS/pano4d/export
};

int RunExport(const ExportCommandOptions& o) {
  const FittedWorkspace fitted = LoadFittedWorkspace(o.workspace);
  const fs::path out =
      o.out.empty() ? o.workspace / "pano4d" / "export" : o.out;
  EnsureDirectory(out / "ply");
  const GaussianScene& scene = fitted.scene;
  GaussianModel posed;
  int written = 0;
  if (scene.has_motion()) {
    ProgressBar bar("export ply", scene.num_times);
    for (int t = 0; t < scene.num_times; ++t) {
      scene.ComposeAt(t, &posed);
      WritePly(out / "ply" / ("t_" + Padded(t, 5) + ".ply"), posed);
      ++written;
      bar.Add();
    }
    bar.Finish();
  } else {
    // No motion: one scene holds for every time.
    scene.ComposeAt(0, &posed);
    WritePly(out / "ply" / "static.ply", posed);
    written = 1;
  }
  std::vector<TrainingView> sources;
  for (const WorkspaceFrame& f : fitted.frames.train) {
    TrainingView v;
    v.name = f.name;
    v.time = f.time;
    v.camera = RasterCamera::FromPosed(f.camera);
    sources.push_back(std::move(v));
  }
  const fs::path trajectories =
      o.workspace / "pano4d" / "expansion" / "trajectories.json";
  const std::vector<ExpandedView> expanded =
      fs::exists(trajectories) ? ReadTrajectories(trajectories)
                               : std::vector<ExpandedView>{};
  WriteTrajectories(out, expanded, sources);
  std::printf(
      "pano4d export: %d PLY file(s) (%zu Gaussians each%s) in %s\n"
      "  cameras: %zu training and %zu expanded, as a COLMAP model in %s\n",
      written, posed.size(),
      scene.has_motion() ? ", one file per time step" : ", no motion",
      (out / "ply").c_str(), sources.size(), expanded.size(),
      (out / "colmap").c_str());
  return kExitOk;
}

}  // namespace

void AddRenderCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<RenderCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "render",
      "Render novel-view videos of the fitted scene (orbit, spiral, bullet "
      "time, or a camera file)");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (frames.json and the fit checkpoint)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option(
         "--trajectory", o->trajectory,
         "orbit (about the up axis through the scene's centre, time "
         "running), spiral (a circle around the middle input view, time "
         "running), bullet (time frozen, swinging), or a JSON file "
         "{\"views\": [{\"camera\": {width, height, fx, fy, cx, cy, qvec, "
         "tvec}, \"t\": T}]} such as WS/pano4d/expansion/trajectories.json")
      ->capture_default_str();
  sub->add_option("--time", o->time,
                  "The time shown: bullet time (default the middle), or for "
                  "a camera file every view's");
  sub->add_option("--frames", o->frames, "Frames of orbit, spiral, bullet")
      ->capture_default_str();
  sub->add_option("--degrees", o->degrees,
                  "The arc (orbit, default 360), circle radius (spiral, 10) "
                  "or swing (bullet, 60)");
  sub->add_option("--fps", o->fps, "Frames per second of the MP4")
      ->capture_default_str();
  sub->add_option("--out", o->out,
                  "Output folder (default WS/pano4d/renders/<trajectory>)");
  sub->footer(
      "Writes OUT/00000.png ..., OUT/<trajectory>.mp4 and OUT/cameras.json "
      "(the cameras in the camera-file layout, to edit and render again).");
  sub->callback([action, o] { *action = [o] { return RunRender(*o); }; });
}

void AddExportCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<ExportCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "export",
      "Export 3DGS PLY per time step and the cameras as a COLMAP model");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (frames.json and the fit checkpoint)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--out", o->out, "Output folder (default WS/pano4d/export)");
  sub->footer(
      "Writes OUT/ply/t_<time>.ply (the 3DGS layout that SuperSplat, "
      "gsplat's viewer and the INRIA viewer open; OUT/ply/static.ply for a "
      "scene without motion), OUT/trajectories.json and OUT/colmap/ "
      "(cameras.txt, images.txt, points3D.txt: the training cameras as "
      "source/<frame>.png beside the expanded ones; COLMAP's GUI: File > "
      "Import model).");
  sub->callback([action, o] { *action = [o] { return RunExport(*o); }; });
}

}  // namespace pano4d::cli
